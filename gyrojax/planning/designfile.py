"""Design files: a :class:`~gyrojax.planning.optimal.DesignResult` as JSON and back, in the result protocol of
:mod:`gyrojax.protocol` (format tag ``"gyrojax-design"``, integer ``format_version``, strict JSON).

The file keeps what the result holds: the model, the criterion, the table (axes, mounting and site; its model
arrays are rebuilt from them), the noise, the designed positions (deg) and dwells (s), the convergence report and
the Fisher information. :func:`load_design` gives back an equal result; the plan to run is :meth:`DesignResult.plan`
(a plan file, :mod:`gyrojax.data.planfile`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gyrojax import protocol
from gyrojax.errors import FormatError, ModelError
from gyrojax.noise.spec import NoiseSpec
from gyrojax.physics.model import Model
from gyrojax.planning.criteria import Criterion
from gyrojax.planning.fisher import Table
from gyrojax.planning.optimal import DesignResult

DESIGN_FORMAT = "gyrojax-design"
DESIGN_VERSION = 1
_KEYS = ("model", "criterion", "table", "noise", "dt_s", "angles_deg", "dwell_s", "loss", "history", "grad_norm")


def design_to_dict(res: DesignResult) -> dict:
    """The JSON-ready payload of a design (angles deg, dwell s, dt s, latitude deg, noise as its saved
    :class:`~gyrojax.noise.spec.NoiseSpec`)."""
    t, c = res.table, res.criterion
    return {
        "model": {"terms": list(res.model.terms), "kind": res.model.kind},
        "criterion": {
            "kind": c.kind,
            "vector": None if c.vector is None else list(c.vector),
            "effect": c.effect,
            "magnitude": None if c.magnitude is None else list(c.magnitude),
            "d_weight": c.d_weight,
        },
        "table": {
            "axes": [[n, list(u)] for n, u in zip(t.axis_names, t.axes_enu)],
            "mount": dict(t.mount),
            "latitude_deg": t.latitude_deg,
        },
        "noise": res.noise.to_json(),
        "dt_s": res.dt_s,
        "angles_deg": np.asarray(res.angles_deg),
        "dwell_s": np.asarray(res.dwell_s),
        "loss": res.loss,
        "history": np.asarray(res.history),
        "grad_norm": res.grad_norm,
        "start_losses": np.asarray(res.start_losses),
        "fisher": None if res.fisher is None else np.asarray(res.fisher),
        "timing": dict(res.timing),
    }


def save_design(res: DesignResult, path, force: bool = False) -> Path:
    """Write a design to ``path`` (strict JSON, atomically; an existing file only with ``force``); returns it."""
    return protocol.save(path, design_to_dict(res), DESIGN_FORMAT, DESIGN_VERSION, force=force)


def _tuple(v):
    return None if v is None else tuple(float(x) for x in v)


def design_from_dict(d: dict, where: str = "design") -> DesignResult:
    """A design from its file payload (:func:`design_to_dict`); :class:`~gyrojax.errors.FormatError` names the key
    that is missing or malformed."""
    protocol.require(d, _KEYS, where)
    try:
        m, c, t, n = d["model"], d["criterion"], d["table"], d["noise"]
        model = Model.of(m["terms"], m["kind"])
        crit = Criterion(c["kind"], _tuple(c["vector"]), c["effect"], _tuple(c["magnitude"]), float(c["d_weight"]))
        table = Table.of(tuple((a, tuple(u)) for a, u in t["axes"]), dict(t["mount"]), float(t["latitude_deg"]))
        noise = (  # a saved NoiseSpec, or the {"arw", "gm"} of the first version-1 files
            NoiseSpec.from_json(n, f"{where}: key 'noise'")
            if protocol.FORMAT_KEY in n
            else NoiseSpec(white=float(n["arw"]), gauss_markov=() if n["gm"] is None else (_tuple(n["gm"]),))
        )
    except (KeyError, TypeError, ValueError, ModelError) as e:
        key = f" {e}" if isinstance(e, KeyError) else f": {e}"
        raise FormatError(f"{where}: key 'model', 'criterion', 'table' or 'noise' is malformed{key}") from None
    fisher = d.get("fisher")
    return DesignResult(
        protocol.floats(d["angles_deg"]).reshape(-1, len(table.axis_names)),
        protocol.floats(d["dwell_s"]),
        float(protocol.floats(d["loss"])),
        crit,
        model,
        table,
        noise,
        float(d["dt_s"]),
        protocol.floats(d["history"]),
        float(protocol.floats(d["grad_norm"])),
        protocol.floats(d.get("start_losses", [])),
        None if fisher is None else protocol.floats(fisher).reshape(model.size, model.size),
        {k: float(v) for k, v in (d.get("timing") or {}).items()},
    )


def load_design(path) -> DesignResult:
    """Read a design written by :func:`save_design`; errors name the file and the key."""
    return design_from_dict(protocol.load(path, DESIGN_FORMAT, DESIGN_VERSION), str(path))
