"""Let the plugin's own tests import it from src/ without installing it.

The package is loaded by file location rather than by putting src/ on
sys.path: a stray ``*.egg-info`` there (left by ``pip install ./tests/plugin_pkg``)
would otherwise make importlib.metadata, and so snakesim's registry, see the
plugin's entry point in every test of the session.
"""

import importlib.util
import sys
from pathlib import Path

PACKAGE = Path(__file__).parent / "src" / "snakesim_demo_plugin"

if "snakesim_demo_plugin" not in sys.modules:
    spec = importlib.util.spec_from_file_location("snakesim_demo_plugin", PACKAGE / "__init__.py",
                                                  submodule_search_locations=[str(PACKAGE)])
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
