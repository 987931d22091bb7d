"""The machine and its model: URDF and kinematics (:mod:`~volerr_pin.model.urdf`, :mod:`~volerr_pin.model.kinematics`), the error
specification and its terms (:mod:`~volerr_pin.model.spec`, :mod:`~volerr_pin.model.terms`, :mod:`~volerr_pin.model.effects`, :mod:`~volerr_pin.model.termkinds`,
:mod:`~volerr_pin.model.speckeys`), the model core (the assembled model :mod:`~volerr_pin.model.assembly` and its evaluations
:mod:`~volerr_pin.model.evaluate`, with the checks of :mod:`~volerr_pin.model.inputs` and :mod:`~volerr_pin.model.state`), the checked front end
:class:`~volerr_pin.model.machine.Machine`, edits of a machine's spec (:mod:`~volerr_pin.model.specio`),
workspaces (:mod:`~volerr_pin.model.workspace`) and plain-data descriptions (:mod:`~volerr_pin.model.describe`)."""
