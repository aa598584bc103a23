"""How a model travels to worker processes: as its registered name and parameters, rebuilt
once per process, so that compiled kernels and caches are never pickled."""

from __future__ import annotations

from typing import Any

from ...models.base import Model

_MODEL_CACHE: dict[tuple[str, str], Model] = {}


class ModelHandle:
    """A model that travels to worker processes as its registered name and parameters; one that
    is not the registered class of its name (a test's own subclass) is pickled whole."""

    def __init__(self, model: Model) -> None:
        self.model = model

    def __getstate__(self) -> dict[str, Any]:
        from ...config.registry import MODELS, model_class

        m = self.model
        if m.name in MODELS and model_class(m.name) is type(m):
            return {"name": m.name, "params": m.params.model_dump_json()}
        return {"model": m}

    def __setstate__(self, state: dict[str, Any]) -> None:
        if "model" in state:
            self.model = state["model"]
            return
        key = (state["name"], state["params"])
        if key not in _MODEL_CACHE:
            from ...config.registry import model_class

            cls = model_class(state["name"])
            _MODEL_CACHE[key] = cls(cls.Params.model_validate_json(state["params"]))
        self.model = _MODEL_CACHE[key]
