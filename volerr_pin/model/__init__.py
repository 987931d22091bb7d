"""The machine and its model, in Pinocchio's shape: a :class:`Model` built once per structure,
free algorithms that take it first, and the :class:`Machine` a user holds.

- The description: :class:`MachineSpec` (axes, bodies, frames, components and their terms,
  edited as typed values: :meth:`MachineSpec.with_terms`, :meth:`MachineSpec.without` ...),
  read from its file by :func:`load_spec` and written back by :func:`write_spec`; the URDF
  (:class:`URDF`, :func:`load_urdf`); the error terms (:class:`Term` and its kinds).
- The model: :func:`build_model` injects six error joints per site into the URDF, builds
  Pinocchio's model and flattens the chain from the workpiece to the tool (:class:`Model`).
- The algorithms, free functions of a model, coefficients ``theta`` and covariates, checked
  at the door by size only: :func:`volumetric_error`, :func:`tool_poses`,
  :func:`sensitivity`, :func:`component_sensitivity`, :func:`error_joint_sensitivity`,
  :func:`axis_jacobian`, :func:`joint_jacobian`, :func:`joint_values`,
  :func:`component_values`, :func:`parameter_jacobian`, :func:`pinocchio_configuration`,
  :func:`search_grid`.
- The value checks of what users give, made once where it enters: :func:`check_inputs` and
  its parts (:func:`check_q`, :func:`check_theta`, :func:`check_covariates`, ...).
- :class:`Machine` = (model, theta, state), whose methods check and call the algorithms;
  :func:`load_machine`; the bundled machines (:func:`bundled_machines`).
- Workspaces (:func:`grid`, :func:`sample`, :func:`field_grid`, :func:`evaluate_field`,
  :func:`error_summary` ...) and plain-data descriptions (:func:`machine_info`).

Names load when first used (PEP 562): listing the bundled machines does not load Pinocchio.
"""

from ..base import lazy_exports

#: public name -> the private module that defines it
_NAMES = {
    "_model": ("Model", "build_model", "ComponentSite", "BLOCK_BYTES"),
    "_algorithms": ("axis_jacobian", "component_sensitivity", "component_values", "error_joint_sensitivity",
                    "joint_jacobian", "joint_values", "parameter_jacobian", "pinocchio_configuration", "search_grid",
                    "sensitivity", "tool_poses", "volumetric_error"),
    "_checks": ("COVARIATES", "check_covariates", "check_inputs", "check_parameters", "check_q", "check_theta",
                "merge_state", "outside_travel", "plausible_theta", "theta_bounds"),
    "_machine": ("Machine", "load_machine"),
    "_catalog": ("SPEC_FILE", "bundled_machines", "machines_dir"),
    "_spec": ("AxisSpec", "BodySpec", "ComponentSpec", "DIRECTIONS", "MachineSpec", "TermSpec", "axis_travel",
              "build_term", "component_name", "load_spec", "parse_component_name", "read_toml", "spec_from_urdf"),
    "_terms": ("Constant", "Context", "Covariates", "LinearTerm", "MAX_COEFFICIENTS", "Polynomial", "Table",
               "TemperatureHistory", "Term"),
    "_effects": ("Backlash", "DriftTemperature", "DriftTime", "EFFECTS", "ExpansionTemperature", "ExpansionTime",
                 "ForceDeflection", "PeriodicPitch", "lagged_name"),
    "_termkinds": ("GEOMETRIC", "KINDS", "read_term", "term_class"),
    "_urdf": ("ENDLESS_TRAVEL", "MAX_JOINTS", "MAX_MODEL_JOINTS", "MAX_URDF_BYTES", "URDF", "checked_meshes",
              "complete_limits", "load_urdf", "package_folders", "parse_urdf"),
    "_specio": ("MAX_DEGREE", "add_terms", "check_values", "legendre_terms", "replace_terms", "spec_document", "write_spec"),
    "_workspace": ("FieldData", "config_from_file", "default_config", "error_summary", "evaluate_field", "field_grid",
                   "from_engineering", "grid", "nice_scale", "sample", "to_engineering"),
    "_describe": ("machine_info",),
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, _NAMES)   # by concept, as the docstring goes
