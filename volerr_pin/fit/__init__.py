"""Fitting the model to measurements: identification (:mod:`~volerr_pin.fit.identify`), what the data can
tell apart (:mod:`~volerr_pin.fit.identifiability`), which error sources matter (:mod:`~volerr_pin.fit.ranking`), and the
diagnosis of what the model misses (:mod:`~volerr_pin.fit.diagnosis`)."""
