"""volerr_pin: volumetric error of machine tools as multibody systems on Pinocchio."""

from .base import InputError, SpecError, URDFError, VolerrError, lazy_exports

__version__ = "0.1.0"

#: names imported when first used (PEP 562): the model loads Pinocchio, SciPy and Numba, and the
#: diagnosis the fitting machinery, which ``import volerr_pin`` (and every command's start,
#: ``volerr --help`` and shell completion included) would otherwise pay for
_NAMES = {"model": ("Machine", "bundled_machines", "load_machine"), "fit.diagnosis": ("diagnose",)}
__getattr__, _lazy_dir, _lazy = lazy_exports(__name__, _NAMES)

__all__ = ["InputError", "SpecError", "URDFError", "VolerrError", *_lazy, "__version__"]


def __dir__():
    return list(__all__)
