"""A PCE method's surrogate in the result file, and back.

Under ``/methods/<label>/surrogate``: the input-to-germ map, per output the multi-indices and
coefficients of its orthonormal basis (factored through principal components for a series), and
the derived outputs' carriers (:func:`write_surrogate`). :func:`read_surrogate` gives a
:class:`StoredSurrogate`, which evaluates as the fitted surrogate did.

The layout: docs/result-file.md#the-kept-surrogate.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any

import h5py
import numpy as np

if TYPE_CHECKING:  # the PCE package is imported only where a surrogate is used
    from ..pce.surrogate import Surrogate


class StoredSurrogate:
    """The arrays of a surrogate read from a result file, before the germ is rebuilt: per output
    ``(alpha, core, mix or None, shape, kind)``, per derived output ``(carriers, kind)``."""

    def __init__(self, inputs: list[str], outputs: dict[str, tuple[Any, ...]],
                 derived: dict[str, tuple[tuple[str, ...], str]]) -> None:
        self.inputs, self.outputs, self.derived = inputs, outputs, derived

    def __repr__(self) -> str:
        from ..pce.surrogate import summary

        rows = [(name, alpha, None if mix is None else mix.shape[0], shape, kind, None)
                for name, (alpha, core, mix, shape, kind) in self.outputs.items()]
        return summary("StoredSurrogate (from a file; Result.surrogate(label) rebuilds it)",
                       self.inputs, rows,
                       {name: carriers for name, (carriers, _) in self.derived.items()},
                       full=".outputs[name] = (alpha, core, mix, shape, kind); "
                            "coefficients core @ mix")

    def resolve(self, germ: Any, derivations: Any) -> Surrogate:
        """The :class:`Surrogate` on ``germ`` with the model's ``derivations`` (name ->
        DerivedOutput) of the stored derived outputs."""
        from ..pce.expansion import Expansion
        from ..pce.surrogate import Surrogate

        exps = {name: Expansion(germ, alpha, core, shape, mix)
                for name, (alpha, core, mix, shape, _) in self.outputs.items()}
        kinds = {name: v[4] for name, v in self.outputs.items()}
        derived = {name: derivations[name] for name in self.derived if name in derivations}
        return Surrogate(germ, exps, derived, kinds)


def write_surrogate(g: h5py.Group, s: Surrogate) -> None:
    """``s`` into the (new, empty) group ``g`` (module docstring)."""
    from ..pce.surrogate import germ_map

    m = germ_map(s.germ)
    g.attrs["inputs"] = json.dumps(list(s.germ.space.names))
    g.attrs["germ_family"] = json.dumps(list(m.family))
    g.attrs["groups"] = json.dumps([[list(idx), np.asarray(L).tolist()] for idx, L in m.groups])
    g.create_dataset("germ_shift", data=m.shift)
    g.create_dataset("germ_scale", data=m.scale)
    g.create_dataset("germ_log", data=m.log.astype(np.uint8))
    for name, e in s.expansions.items():
        o = g.create_group(f"outputs/{name}")
        o.attrs["kind"] = s.kinds.get(name, "series" if len(e.shape) == 2 else "scalar")
        o.attrs["shape"] = json.dumps([int(v) for v in e.shape])
        o.create_dataset("alpha", data=np.asarray(e.alpha, dtype=np.int32))
        big = e.core.size > 4096
        o.create_dataset("core", data=e.core, compression="gzip" if big else None)
        if e.mix is not None:
            o.create_dataset("mix", data=e.mix,
                             compression="gzip" if e.mix.size > 4096 else None)
    for name, dv in s.derived.items():
        d = g.create_group(f"derived/{name}")
        d.attrs["carriers"] = json.dumps(list(dv.carriers))
        d.attrs["kind"] = dv.kind


def read_surrogate(g: h5py.Group) -> StoredSurrogate:
    """The arrays written by :func:`write_surrogate`."""
    outputs = {}
    for name, o in g.get("outputs", {}).items():
        outputs[name] = (o["alpha"][()].astype(int), o["core"][()],
                         o["mix"][()] if "mix" in o else None,
                         tuple(json.loads(o.attrs["shape"])), str(o.attrs["kind"]))
    derived = {name: (tuple(json.loads(d.attrs["carriers"])), str(d.attrs["kind"]))
               for name, d in g.get("derived", {}).items()}
    return StoredSurrogate(json.loads(g.attrs["inputs"]), outputs, derived)
