"""Scene and sub-assembly YAML files shipped with snakesim (found at run time through importlib.resources)."""
