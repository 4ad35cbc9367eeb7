"""DXF files of the drawings through ezdxf (imported here only, when a DXF is written).

DXF R2000 (AC1015), millimetres ($INSUNITS 4, $MEASUREMENT 1), with R12-era entities that laser
and CAM software read: LINE, CIRCLE, LWPOLYLINE (its arcs as bulges: exact arcs, no chords) and
TEXT; no blocks, splines or hatches. One layer per kind of line (planarkin.export.geometry.LAYERS):
OUTLINE is what is cut, HOLES the pin holes, CENTRES the centre marks, PITCH the reference curves
(cam pitch curves, gear pitch circles), TEXT the notes.
"""

from __future__ import annotations

from pathlib import Path

from . import geometry as geo

VERSION = "R2000"
MILLIMETRES = 4          # $INSUNITS


def missing() -> str | None:
    """Why DXF files cannot be written here (ezdxf missing), or None."""
    try:
        import ezdxf  # noqa: F401
    except ImportError:
        return "--dxf needs ezdxf: pip install 'planarkin[drawings]' (or pip install ezdxf)"
    return None


def document(shapes, texts):
    """The ezdxf document of shapes and texts (mm)."""
    import ezdxf
    doc = ezdxf.new(VERSION, units=MILLIMETRES)
    for name, (colour, _) in geo.LAYERS.items():
        doc.layers.add(name, color=colour)
    msp = doc.modelspace()
    for s in shapes:
        attrs = {"layer": s.layer}
        if s.kind == "circle":
            msp.add_circle(tuple(map(float, s.points[0])), float(s.r), dxfattribs=attrs)
        elif s.kind == "line":
            msp.add_line(tuple(map(float, s.points[0])), tuple(map(float, s.points[1])),
                         dxfattribs=attrs)
        else:
            msp.add_lwpolyline([(float(x), float(y), float(b))
                                for (x, y), b in zip(s.points, s.bulges)],
                               format="xyb", close=s.closed, dxfattribs=attrs)
    for t in texts:
        msp.add_text(t.text, height=t.height,
                     dxfattribs={"layer": geo.TEXT, "insert": tuple(map(float, t.at))})
    return doc


def write(path: Path, shapes, texts) -> None:
    """Write the DXF file (an OSError is the caller's: disk full, permissions). The header's
    dates and GUIDs are ezdxf's fixed ones, so that identical input gives identical bytes, as
    every other output does."""
    import ezdxf
    from ezdxf.document import CREATED_BY_EZDXF
    doc = document(shapes, texts)
    # ezdxf stamps the moment the document was made into its metadata: the version alone
    doc.ezdxf_metadata()[CREATED_BY_EZDXF] = f"ezdxf {ezdxf.__version__}"
    old = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = True
    try:
        doc.saveas(path)
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = old
