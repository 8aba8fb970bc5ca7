"""snakesim.components: plug-in physical and signal models, registered through the same hooks as third-party plugins."""
