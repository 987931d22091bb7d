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
    if name in OLD_NAMES:   # volerr_pin.machine as an attribute, as before the layout: warns
        return _import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return list(__all__)


#: the modules' names before the package was laid out in layers (2026-11): still importable for
#: one release, with a DeprecationWarning naming the new place
OLD_NAMES = {
    "errors": "base.errors", "units": "base.units", "checks": "base.checks", "safeio": "base.safeio", "kinematics":
    "model.kinematics", "urdf": "model.urdf", "spec": "model.spec", "terms": "model.terms", "effects":
    "model.effects", "termkinds": "model.termkinds", "speckeys": "model.speckeys", "assembly": "model.assembly",
    "evaluate": "model.evaluate", "inputs": "model.inputs", "state": "model.state", "machine": "model.machine",
    "workspace": "model.workspace", "specio": "model.specio", "describe": "model.describe", "simulate":
    "measurements.simulate", "identify": "fit.identify", "diagnosis": "fit.diagnosis", "identifiability":
    "fit.identifiability", "ranking": "fit.ranking", "gcode": "compensation.gcode", "export": "compensation.export",
    "errormap": "compensation.errormap", "plan": "studies.plan", "gear": "applications.gear", "iso230":
    "applications.iso230", "thermal": "applications.thermal", "thermalfit": "applications.thermalfit", "dh":
    "applications.dh", "axisfit": "applications.axisfit", "compensate": "compensation"}


class _OldNames:
    """Finds a module by its old name (:data:`OLD_NAMES`, and anything under an old package)
    and gives the module of the new name: the same object, so that patching one patches both."""

    @staticmethod
    def find_spec(fullname, path=None, target=None):
        import importlib.util

        parts = fullname.split(".")
        if parts[0] != __name__ or len(parts) < 2 or parts[1] not in OLD_NAMES:
            return None
        new = ".".join([__name__, OLD_NAMES[parts[1]], *parts[2:]])
        if importlib.util.find_spec(new) is None:
            return None
        return importlib.util.spec_from_loader(fullname, _OldNames(new))

    def __init__(self, new: str):
        self.new = new

    def create_module(self, spec):
        import warnings

        warnings.warn(f"{spec.name} is {self.new} now; the old name goes in the next release", DeprecationWarning,
                      stacklevel=2)
        module = _import_module(self.new)
        self.spec = module.__spec__
        return module

    def exec_module(self, module):
        module.__spec__ = self.spec   # the import system set the old name's: the module keeps its own


def _install_old_names() -> None:
    import sys

    if _OldNames not in sys.meta_path:
        sys.meta_path.insert(0, _OldNames)   # before the path finder, which would load a second copy


_install_old_names()
