"""Robot descriptions: parametric URDF generators, generated URDFs and meshes."""
