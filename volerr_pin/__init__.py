"""volerr_pin: volumetric error of machine tools as multibody systems on Pinocchio."""

from .errors import InputError, SpecError, URDFError, VolerrError
from .machine import Machine, bundled_machines, load_machine

__version__ = "0.1.0"

__all__ = ["InputError", "Machine", "SpecError", "URDFError", "VolerrError", "bundled_machines",
           "load_machine", "__version__"]
