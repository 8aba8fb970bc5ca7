"""Maps the repository's top-level folders onto the `snakesim` namespace.

Everything else lives in pyproject.toml; this file exists only because the
folder-to-package mapping (framework/ -> snakesim.framework, ...) needs the
list of subpackages computed, which static pyproject metadata cannot do.
"""

from setuptools import find_namespace_packages, setup

ROOTS = ["framework", "components", "assemblies", "robots", "terrains", "configs", "campaigns"]
# snakesim.gym (the Gymnasium environments, extra [gym]) lives in gymenv/: a folder named gym/ at the
# repository root would shadow the `gym` package for anything run from there (the working directory
# comes first on sys.path)
RENAMED = {"gym": "gymenv"}

packages, package_dir = [], {}
for name, root in [(r, r) for r in ROOTS] + list(RENAMED.items()):
    package_dir[f"snakesim.{name}"] = root
    packages.append(f"snakesim.{name}")
    # every folder, data-only ones too (robots/urdf, configs/friction, ...): a folder left out of
    # `packages` still ships its files, but setuptools warns "Package would be ignored" for each
    packages += [f"snakesim.{name}.{sub}" for sub in find_namespace_packages(root, exclude=["*__pycache__*"])]

setup(packages=packages, package_dir=package_dir)
