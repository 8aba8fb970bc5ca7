"""Kernel argument records: a kernel takes a few named records instead of 20-40 positions.

A record is a numba StructRef: a fixed set of named fields (arrays, numbers, flags) that a
kernel reads as ``rec.field``. A component builds two kinds:

* constants, once in ``setup()`` (a robot's tree arrays, a contact's sample tables);
* per-run records in ``make_cache(x, u, y)``, against this plan's buffers: views of the
  state ``x``, the input views, the output arrays (the framework never reallocates them)
  and the run's scratch.

``bind(kernel, *records)`` compiles the kernel (or loads it from numba's disk cache) for
exactly these records' types, once, at build, and returns a call without arguments. A
bound call skips numba's per-call argument typing: it costs ~0.2 µs where the dispatcher
spends ~1 µs per record, or ~65 ns per positional array. A record's fields cannot be
rebound, so the compiled types fit for the call's whole life.

    Tree = record("Tree", ("order", "parent", "R0"))              # at module level
    tree = Tree(order=..., parent=..., R0=...)                       # in setup()
    step = bind(kernel, tree, run)                                   # in make_cache()
    step()                                                           # in the hot path

From Python a record is opaque (keep your own references to its arrays); ``Tree.fields``
lists its field names. Records are built by one cached numba function, so a new
combination of field types compiles once (~0.5 s) and then loads from the disk cache.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

from numba import njit, typeof
from numba.core import cgutils, types
from numba.core.extending import intrinsic
from numba.experimental import structref


@intrinsic
def _from_tuple(typingctx, struct_typeref, values):
    """A new record of type ``struct_typeref`` holding ``values`` (a tuple in field order)."""
    inst_type = struct_typeref.instance_type
    names = list(inst_type.field_dict)

    def codegen(context, builder, signature, args):
        from numba.experimental.jitclass.base import imp_dtor

        # as structref.new: allocate the payload (its destructor decrefs the fields), zeroed
        alloc_type = context.data_model_manager[inst_type.get_data_type()].get_value_type()
        meminfo = context.nrt.meminfo_alloc_dtor(
            builder, context.get_constant(types.uintp, context.get_abi_sizeof(alloc_type)),
            imp_dtor(context, builder.module, inst_type))
        data = builder.bitcast(context.nrt.meminfo_data(builder, meminfo), alloc_type.as_pointer())
        builder.store(cgutils.get_null_value(alloc_type), data)
        inst = context.make_helper(builder, inst_type)
        inst.meminfo = meminfo
        inst = inst._getvalue()
        fields = structref._Utils(context, builder, inst_type).get_data_struct(inst)
        for i, name in enumerate(names):
            field_type = inst_type.field_dict[name]
            value = context.cast(builder, builder.extract_value(args[1], i), values[i], field_type)
            context.nrt.incref(builder, field_type, value)
            setattr(fields, name, value)
        return inst

    return inst_type(struct_typeref, values), codegen


@njit(cache=True)
def _new(struct_typeref, values):
    return _from_tuple(struct_typeref, values)


class RecordType(types.StructRef):
    """The numba type of every record: its fields (names and types) tell records apart. One type
    class for all, defined here, so numba's disk cache can always unpickle a kernel's signatures
    (a type class per record kind would tie the cache index to the module defining each kind)."""

    def preprocess_fields(self, fields):
        return tuple((n, types.unliteral(t)) for n, t in fields)


structref.register(RecordType)


class Record(structref.StructRefProxy):
    """A kernel argument record, as Python sees it: opaque (keep your own references to its arrays)."""

    def __repr__(self):
        return f"<record {', '.join(self._type.field_dict)}>"


structref.define_boxing(RecordType, Record)


class RecordKind:
    """Builds records with a fixed list of fields: ``Tree(order=..., parent=...)``; every field is
    required, by keyword. A record is typed by its fields' values (arrays: dtype, dimensions,
    layout, read-only or not), so one kind may give several numba types."""

    def __init__(self, name: str, fields: Sequence[str]):
        self.name, self.fields = name, tuple(fields)

    def __call__(self, **values) -> Record:
        if values.keys() != set(self.fields):
            raise TypeError(f"{self.name}: missing fields {[f for f in self.fields if f not in values]}, "
                            f"unknown fields {[k for k in values if k not in self.fields]}")
        vals = tuple(values[f] for f in self.fields)
        return _new(RecordType([(f, typeof(v)) for f, v in zip(self.fields, vals)]), vals)

    def __repr__(self):
        return f"<record kind {self.name}: {', '.join(self.fields)}>"


def record(name: str, fields: Sequence[str]) -> RecordKind:
    """A record kind with these fields (a module-level constant of the kernels' module)."""
    return RecordKind(name, fields)


def bind(kernel, *args):
    """``kernel`` compiled once for exactly these arguments' types; returns ``call()`` -> its result.

    For records and other objects fixed for the run: every call passes the same objects,
    without numba's per-call typing and overload look-up."""
    entry = kernel.compile(tuple(kernel.typeof_pyval(a) for a in args))
    return functools.partial(entry, *args)
