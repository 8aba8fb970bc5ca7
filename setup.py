"""Maps the repository's top-level folders onto the `snakesim` namespace.

Everything else lives in pyproject.toml; this file exists only because the
folder-to-package mapping (framework/ -> snakesim.framework, ...) needs the
list of subpackages computed, which static pyproject metadata cannot do.
"""

from setuptools import find_namespace_packages, setup

ROOTS = ["framework", "components", "assemblies", "robots", "terrains", "configs", "campaigns"]

packages, package_dir = [], {}
for root in ROOTS:
    package_dir[f"snakesim.{root}"] = root
    packages.append(f"snakesim.{root}")
    # every folder, data-only ones too (robots/urdf, configs/friction, ...): a folder left out of
    # `packages` still ships its files, but setuptools warns "Package would be ignored" for each
    packages += [f"snakesim.{root}.{sub}" for sub in find_namespace_packages(root, exclude=["*__pycache__*"])]

setup(packages=packages, package_dir=package_dir)
