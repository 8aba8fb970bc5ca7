"""Terrain definitions and assets (YAML, DEMs, meshes)."""
