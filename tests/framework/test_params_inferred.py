"""``Component[P]`` names the parameters once: ``Params`` is taken from the type argument."""

import pytest

from snakesim.framework import Component
from snakesim.framework.component import Params


class GainParams(Params):
    k: float = 2.0


class OtherParams(Params):
    k: float = 3.0


def test_params_come_from_the_type_argument():
    class Gain(Component[GainParams]):
        pass

    assert Gain.Params is GainParams
    assert Gain("g", k=4.0).p.k == 4.0

    class Sub(Gain):                       # a subclass keeps its parent's
        pass

    assert Sub.Params is GainParams


def test_an_explicit_params_still_works_and_must_agree():
    class Same(Component[GainParams]):
        Params = GainParams

    assert Same.Params is GainParams

    with pytest.raises(TypeError, match=r"Params = OtherParams differs from the type argument GainParams"):
        class Differs(Component[GainParams]):
            Params = OtherParams


def test_every_registered_component_has_its_type_argument_as_params():
    from snakesim.framework.registry import default_registry

    for name, cls in default_registry().components.items():
        args = [a for b in vars(cls).get("__orig_bases__", ()) for a in getattr(b, "__args__", ())
                if isinstance(a, type)]
        if args:
            assert cls.Params in args, name
