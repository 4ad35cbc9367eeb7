"""A DXF drawing drawn to a PNG with ezdxf's matplotlib add-on (ezdxf.addons.drawing): a look at
a sheet without a CAD program, and the how-to page's figure (docs/how-to/drawings.md)."""

from __future__ import annotations

from pathlib import Path


def render(dxf_path, png_path, dpi: int = 150, width: float = 8.0) -> Path:
    """Draw the DXF file's modelspace on a white background into png_path (width in inches)."""
    import ezdxf
    from ezdxf.addons.drawing import Frontend, RenderContext
    from ezdxf.addons.drawing.config import BackgroundPolicy, Configuration
    from ezdxf.addons.drawing.matplotlib import MatplotlibBackend
    from matplotlib.figure import Figure     # not pyplot: the caller's backend stays its own

    doc = ezdxf.readfile(dxf_path)
    msp = doc.modelspace()
    fig = Figure()
    ax = fig.add_axes([0, 0, 1, 1])
    config = Configuration(background_policy=BackgroundPolicy.WHITE)
    Frontend(RenderContext(doc), MatplotlibBackend(ax), config=config).draw_layout(msp)
    ax.set_aspect("equal")
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    fig.set_size_inches(width, width * (y1 - y0) / (x1 - x0))
    fig.savefig(png_path, dpi=dpi, facecolor="white")
    return Path(png_path)
