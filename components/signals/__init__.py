"""Generic signal blocks: sources, gains, sums, sample-and-hold. No physics."""
