"""snakesim.gym: any scene as a Gymnasium environment (docs/python.md, "A Gymnasium environment").

``SnakesimEnv(scene, observation=[...], action={...}, reward=..., ...)`` over any scene, and two
registered ids, ``snakesim/ScrewTraverse-v0`` and ``snakesim/MiniEelsCrawl-v0``::

    import gymnasium
    import snakesim.gym                     # registers the ids (Gymnasium >= 1.0 reads no plugin entry points)
    env = gymnasium.make("snakesim/ScrewTraverse-v0")
    env = gymnasium.make("snakesim.gym:snakesim/ScrewTraverse-v0")     # the same, with no import first

Gymnasium is an optional extra: ``pip install 'snakesim[gym]'``. This package lives in the
repository's ``gymenv/`` folder (setup.py maps it to ``snakesim.gym``): a folder named ``gym/`` at the
root would shadow the ``gym`` package for anything run from there.
"""

try:
    import gymnasium  # noqa: F401
except ImportError as e:          # pragma: no cover - exercised in a subprocess by the tests
    raise ImportError("snakesim.gym needs Gymnasium, an optional extra: pip install 'snakesim[gym]' "
                      f"(or pip install 'gymnasium>=1.0'); importing it failed: {e}") from e

from .env import Act, Obs, SnakesimEnv, progress
from .envs import ENVS, MiniEelsCrawlEnv, ScrewTraverseEnv, register_envs

__all__ = ["SnakesimEnv", "Act", "Obs", "progress", "ScrewTraverseEnv", "MiniEelsCrawlEnv", "ENVS", "register_envs"]

register_envs()
