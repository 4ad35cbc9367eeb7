"""Fabrication drawings of a model's parts (issue 30, item 1): `planarkin export MODEL --dxf
--svg`. A room fed by the model and, for a posed layout, its Result: it reads the compiled
model's arrays and never imports the command line or the run pipeline.

    drawings.py   every moving body as a part in its body frame, mm: plate, holes, centre marks,
                  cam profiles (exact law, fitted arcs within the tolerance), gear blanks
    geometry.py   shapes (polylines with bulges, circles, lines), the plate around pins, extents
    biarcs.py     a curve as arcs within a chordal tolerance, checked against the curve
    layout.py     the layout sheet: the parts side by side in rows, without overlap
    dxf.py        DXF R2000 through ezdxf (imported only when a DXF is written)
    svg.py        plain-text SVG in millimetres
    preview.py    a DXF drawn to PNG with ezdxf's matplotlib add-on (the docs' figure)
    command.py    the command: options, the result directory DIR/<model>.drawings/

API: ``drawings.parts(planarkin.load(path), drawings.Sizes(width=12))`` gives the parts.
"""
