"""Applications of the model to what users measure and make: ISO 230-2 positioning
(:mod:`~volerr_pin.applications.iso230`), thermal models (:mod:`~volerr_pin.applications.thermal`, :mod:`~volerr_pin.applications.thermalfit`), robots from DH tables
and their axes from circle points (:mod:`~volerr_pin.applications.dh`, :mod:`~volerr_pin.applications.axisfit`), gear flanks generated on a
rolling machine (:mod:`~volerr_pin.applications.gear`), and the part a program cuts (:mod:`~volerr_pin.applications.part`, with the cone frustum of five-axis
machines and what a CMM reports)."""
