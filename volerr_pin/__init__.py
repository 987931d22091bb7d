"""volerr_pin: volumetric error of machine tools as multibody systems on Pinocchio."""

from importlib import import_module as _import_module

from .base.errors import InputError, SpecError, URDFError, VolerrError

__version__ = "0.1.0"

#: names imported when first used (PEP 562): the model loads Pinocchio, SciPy and Numba, and the
#: diagnosis the fitting machinery, which ``import volerr_pin`` (and every command's start,
#: ``volerr --help`` and shell completion included) would otherwise pay for
_LAZY = {"diagnose": ".fit.diagnosis", "Machine": ".model", "bundled_machines": ".model",
         "load_machine": ".model"}

__all__ = ["InputError", "Machine", "SpecError", "URDFError", "VolerrError", "bundled_machines", "diagnose",
           "load_machine", "__version__"]


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(_import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return list(__all__)

