"""Figures as people look at them: a PNG at :data:`FIGURE_DPI` and a PDF beside it."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure

FIGURE_DPI = 200  # PNG resolution; the PDF beside it is vector
VECTOR_SUFFIX = ".pdf"


def vector_path(png: Path) -> Path:
    """The vector copy of a figure: ``trajectories.png`` -> ``trajectories.pdf``.

    Parameters
    ----------
    png : Path
        The PNG.

    Returns
    -------
    Path
    """
    return png.with_suffix(VECTOR_SUFFIX)


def save_figure(fig: Figure, png: Path, *, vector: bool = True, **savefig: Any) -> None:
    """Write ``fig`` as a PNG at :data:`FIGURE_DPI` and as a PDF beside it, then close it.

    The PDF embeds its fonts as TrueType (``pdf.fonttype`` 42, text a paper's editor can
    select) and carries no creation date, so the same figure gives the same bytes.

    Parameters
    ----------
    fig : Figure
        The figure.
    png : Path
        The PNG's path; the PDF is :func:`vector_path` of it.
    vector : bool
        Write the PDF (False: the PNG only; the PDF of a figure costs about twice its PNG,
        most of it embedding the fonts).
    **savefig
        More arguments to ``Figure.savefig`` (``bbox_inches="tight"``, ...).
    """
    import matplotlib
    import matplotlib.pyplot as plt

    fig.savefig(png, dpi=FIGURE_DPI, **savefig)
    if vector:
        with matplotlib.rc_context({"pdf.fonttype": 42}):
            fig.savefig(vector_path(png), metadata={"CreationDate": None}, **savefig)
    plt.close(fig)
