"""The component reference shows what users need: whole docstrings, Literal choices, the port layout."""

from __future__ import annotations

from typing import Literal, Optional

from snakesim.framework.reference import component_reference, reference_markdown, type_name
from snakesim.framework.registry import default_registry


def test_literal_parameters_list_their_choices():
    assert type_name(Literal["auto", "embedded"]) == "one of 'auto', 'embedded'"
    assert type_name(Optional[Literal["a"]]) == "one of 'a' | None"
    ref = component_reference(default_registry())
    screw_pairs = next(p for p in ref["multibody"]["params"] if p["name"] == "screw_pairs")
    assert "'mimic_crba'" in screw_pairs["type"]


def test_the_whole_docstring_is_in_the_reference_never_cut():
    reg = default_registry()
    md = reference_markdown(component_reference(reg))
    for name, cls in reg.components.items():
        own = cls.__dict__.get("__doc__")
        if own and own.strip():
            import inspect
            for para in inspect.cleandoc(own).split("\n\n"):
                assert para.replace("\n", " ") in md or para in md, f"{name}: paragraph missing:\n{para}"


def test_the_multibody_port_layout_is_documented():
    doc = component_reference(default_registry())["multibody"]["doc"]
    for needed in ("qx, .qy, .qz, .qw", "(cos, sin)", "mimic", "omitted"):
        assert needed in doc, needed
