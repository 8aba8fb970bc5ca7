"""Field scans (point clouds, meshes) to mesh terrains: ``snakesim terrain import`` (docs/scan.md).

    open3d_loader.py    Open3D on demand (libusb first); never imported by the core
    errors.py           ScanError: the file and what would be valid
    readers.py          .ply .pcd .xyz .las .laz .stl .obj as they are (file units and frame)
    frames.py           units, up axis, georeferenced offset → the terrain frame
    cleaning.py         outliers, voxel downsampling, spacing, the density check
    normals.py          normals oriented into the void (scanner positions, file normals, void-axis rule)
    reconstruction.py   registered reconstructors (poisson, ball_pivoting) and trimming
    decimation.py       quadric decimation to a face budget
    holes.py            boundary loops: outer rims and interior holes
    report.py           distances, coverage, holes
    terrain_file.py     the mesh and terrain YAML written
    import_scan.py      the pipeline
    import_cli.py       the click command

Importing this package imports neither Open3D nor laspy: each module imports them where used.
"""
