"""Object-ID distillation (paper Sec. 3.3): identity features of the frozen Gaussian field, trained
on the associated per-view object masks, and the classifier Phi that maps them to object ids."""

from importlib import import_module as _import_module

# name -> module: imported on first use, so that the settings (``distill.config``) load without the stage
_EXPORTS = {"DistillConfig": "config", "IdentityField": "field", "read_classifier": "field", "write_classifier": "field",
            "read_objects": "labels", "DistillResult": "stage", "distill_stage": "stage"}  # fmt: skip
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(_import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
