"""Pictures: Rerun recordings (:mod:`volerr_pin.viz.recording`) and static matplotlib figures
(:mod:`volerr_pin.viz.plots`).

The rest of the library computes without them: modelling, identification, diagnosis and
compensation never import Rerun or matplotlib, so importing them costs nothing until a
picture is asked for. Import the submodule you need.
"""
