"""The guide's pictures, drawn during the docs build by the product's own PNG writers.

Each picture is what a reader gets from the command beside it in the guide, run on the sample
data of ``examples/data/``: the build runs the commands of :data:`FIGURES` (in this process,
through :func:`volerr_pin.cli.main`, from the repository's root) into ``docs/images/guide/``,
before the pages are read. A picture is drawn again when it is missing or older than the
package, the bundled machines or the sample data, so a change of the product shows in the next
build. A command that fails stops the build.

The pictures are committed, so that the pages show them where Markdown is read as it is (the
repository's web view) as well as on the site: ``![...](../images/guide/NAME.png)``.
``tests/test_readme.py`` holds that every such link names a picture of :data:`FIGURES` and
that every picture of :data:`FIGURES` is there.
"""

from __future__ import annotations

import contextlib
import io
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "docs" / "images" / "guide"

#: picture name -> the ``volerr`` arguments that draw it ({png}: the picture, {tmp}: a scratch folder)
FIGURES: dict[str, list[str]] = {
    "field_vmc500.png": ["field", "vmc500", "--out", "{tmp}/field.rrd", "--png", "{png}"],
    "rank_vmc500.png": ["rank", "vmc500", "--tolerances", "examples/data/vmc500_tolerances.toml", "--top", "8",
                        "--png", "{png}"],
    "iso230_vmc500_x.png": ["iso230-2", "examples/data/vmc500_x_positioning.csv", "--png", "{png}"],
    "iso230_seed001.png": ["iso230-2", "examples/data/seed001_table1_before.csv", "--png", "{png}"],
    "ballbar_vmc500_xy.png": ["ballbar", "examples/data/vmc500_ballbar_xy.csv", "--png", "{png}"],
    "thermal_vmc500.png": ["thermal-fit", "examples/data/vmc500_spindle_thermal.csv", "--target", "dz_um",
                           "--sensors", "T_housing", "T_column", "--lag", "0", "--holdout", "0.25", "--png", "{png}"],
    "diagnose_vmc500.png": ["diagnose", "vmc500", "examples/data/vmc500_tracker.csv", "--sigma-um", "0.3", "--png",
                            "{png}"],
    "compensate_vmc700.png": ["compensate", "vmc700", "examples/data/part.nc", "-o", "{tmp}/part_comp.nc",
                              "--tol-um", "1", "--png", "{png}"],
    "export_vmc500.png": ["export", "vmc500", "--controller", "linuxcnc", "-o", "{tmp}/comp", "--png", "{png}"],
    "gear_roller_flanks.png": ["gear", "gear_roller", "--png", "{png}"],
    "part_vmc500.png": ["predict", "vmc500", "examples/data/vmc500_testpiece.nc", "--png", "{png}"],
    "part_cgm4000_cone.png": ["predict", "cgm4000", "examples/data/cgm4000_cone.nc", "--tool-diameter", "20",
                              "--cone-heights", "2,10,18", "--png", "{png}"],
    "uncertainty_vmc500.png": ["uncertainty", "vmc500", "--instrument-sigma", "1", "--samples", "2000", "--grid", "5",
                               "--compensation", "point", "--workers", "0", "--png", "{png}"],
}


def _newest_source() -> float:
    sources = [*(ROOT / "volerr_pin").rglob("*.py"), *(ROOT / "machines").rglob("*.toml"),
               *(ROOT / "machines").rglob("*.urdf"), *(ROOT / "examples" / "data").iterdir()]
    return max(p.stat().st_mtime for p in sources if p.is_file())


def draw(names=None, out: Path = OUT, force: bool = False) -> list[Path]:
    """Draw the pictures ``names`` (default: all) into ``out`` where missing or stale.

    Parameters
    ----------
    names : iterable of str, optional
        Keys of :data:`FIGURES`.
    out : Path
        Folder of the pictures (created).
    force : bool
        Draw even a picture that is up to date.

    Returns
    -------
    list of Path
        The pictures drawn in this call.
    """
    from volerr_pin.cli import main

    out.mkdir(parents=True, exist_ok=True)
    newest = _newest_source()
    drawn = []
    for name in names or FIGURES:
        png = out / name
        if not force and png.exists() and png.stat().st_mtime > newest:
            continue
        with tempfile.TemporaryDirectory() as tmp, contextlib.chdir(ROOT):
            argv = [a.format(png=png, tmp=tmp) for a in FIGURES[name]]
            sink = io.StringIO()
            with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
                code = main(argv)
        if code != 0 or not png.exists():
            raise RuntimeError(f"docs figure {name}: volerr {' '.join(FIGURES[name])} failed ({code}):\n"
                               f"{sink.getvalue()}")
        drawn.append(png)
    return drawn


def _builder_inited(app):
    import matplotlib

    matplotlib.use("Agg")
    for png in draw():
        print(f"drew {png.name}")


def setup(app):
    app.connect("builder-inited", _builder_inited)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
