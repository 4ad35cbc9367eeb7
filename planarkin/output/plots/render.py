"""Saving a figure: png drawn by a text-caching Agg renderer and encoded here, svg and pdf
through matplotlib with fixed ids and no date (the same run gives byte-identical files)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .style import DPI


def save_figure(fig, path: Path) -> Path:
    """Save a figure: png at DPI (drawn by `renderer_class`, encoded by `write_png`); svg and
    pdf without a date and (svg) with fixed element ids, so that the same run gives
    byte-identical files."""
    from contextlib import nullcontext

    import matplotlib as mpl

    fmt = path.suffix[1:]
    meta = {"svg": {"Date": None}, "pdf": {"CreationDate": None}}.get(fmt)
    # svg ids are salted with a random uuid unless this rcParam is set: the only rcParams use,
    # for the duration of one save
    salt = mpl.rc_context({"svg.hashsalt": "planarkin"}) if fmt == "svg" else nullcontext()
    if fmt == "png":
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        fig.set_dpi(DPI)
        FigureCanvasAgg(fig)                    # (the figure's canvas, as savefig makes it)
        w, h = fig.bbox.size
        renderer = renderer_class()(int(w), int(h), DPI)
        fig.draw(renderer)
        write_png(path, renderer.buffer_rgba(), DPI)
        return path
    with salt:
        fig.savefig(path, format=fmt, dpi=DPI, metadata=meta)
    # no fig.clear(): tearing the artists down costs a tenth of the drawing; dropping the last
    # reference frees them as well
    return path


def write_png(path: Path, rgba, dpi: int) -> None:
    """Write an opaque RGBA buffer (h, w, 4) as an RGB png: rows unfiltered, zlib level 1, the
    resolution in a pHYs chunk. Half of the time of Pillow's encoder at level 1 (which tries
    every row filter), and the files are a few per cent smaller: plots are mostly runs of one
    colour, which the filters do not shorten."""
    import struct
    import zlib

    a = np.asarray(rgba)
    h, w = a.shape[:2]
    rows = np.empty((h, 3 * w + 1), np.uint8)
    rows[:, 0] = 0                                  # filter type None
    rows[:, 1:].reshape(h, w, 3)[...] = a[:, :, :3]
    z = zlib.compressobj(1)
    data = z.compress(rows) + z.flush()

    def chunk(tag: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body))

    ppm = round(dpi / 0.0254)                       # pixels per metre
    with open(path, "wb") as f:
        f.write(b"".join([b"\x89PNG\r\n\x1a\n",
                          chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)),
                          chunk(b"pHYs", struct.pack(">IIB", ppm, ppm, 1)),
                          chunk(b"IDAT", data), chunk(b"IEND", b"")]))


_RENDERER = []
TEXTS: dict = {}             # (string, font, dpi, antialiased) -> _Rasterised, this process
_TEXTS_MAX = 4096             # entries kept (a few kB each); the cache is emptied when full


class _Rasterised:
    """One string laid out and rasterised by FreeType: its width, height and descent (pixels)
    and its bitmap with the bitmap's offset (FreeType's 1/64 pixels)."""
    __slots__ = ("whd", "image", "offset")

    def __init__(self, font, s, flags, antialiased):
        font.set_text(s, 0.0, flags=flags)
        w, h = font.get_width_height()
        self.whd = (w / 64.0, h / 64.0, font.get_descent() / 64.0)
        font.draw_glyphs_to_bitmap(antialiased=antialiased)
        self.image = font.get_image()
        self.offset = font.get_bitmap_offset()


def renderer_class():
    """RendererAgg, laying out and rasterising each distinct string once per process when this
    matplotlib draws texts glyph by glyph (3.11: a Python loop over the glyphs, each with its own
    transform and image; and FreeType lays the string out again for the drawing after the
    measuring, each time): the string is laid out and rasterised in one call and drawn
    as one image, as matplotlib up to 3.10 did, and the result is kept for the next time the
    same string is measured or drawn in the same font (tick labels, legends and axis labels
    repeat from figure to figure). A string's bitmap does not depend on where it is drawn
    (whole pixels, as up to 3.10), so a figure is the same whether its texts were cached or
    not. Math text and anything else go to matplotlib's own methods."""
    if _RENDERER:
        return _RENDERER[0]
    from matplotlib.backends import backend_agg
    from matplotlib.backends.backend_agg import RendererAgg

    cls = RendererAgg
    if hasattr(RendererAgg, "_draw_text_glyphs_and_boxes"):
        hinting = backend_agg.get_hinting_flag

        class TextRenderer(RendererAgg):
            def _text(self, s, prop, antialiased=True):
                key = (s, tuple(prop.get_family()), prop.get_style(), prop.get_variant(),
                       prop.get_weight(), prop.get_stretch(), prop.get_size_in_points(),
                       prop.get_file(), self.dpi, bool(antialiased))
                r = TEXTS.get(key)
                if r is None:
                    if len(TEXTS) >= _TEXTS_MAX:
                        TEXTS.clear()
                    r = TEXTS[key] = _Rasterised(self._prepare_font(prop), s, hinting(),
                                                  antialiased)
                return r

            def get_text_width_height_descent(self, s, prop, ismath):
                if ismath:
                    return super().get_text_width_height_descent(s, prop, ismath)
                return self._text(s, prop).whd

            def draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
                if ismath:
                    return super().draw_text(gc, x, y, s, prop, angle, ismath, mtext)
                r = self._text(s, prop, gc.get_antialiased())
                # the bitmap is drawn unrotated at angle 0, rotated by draw_text_image
                a = math.radians(angle)
                d = r.whd[2]
                x = round(x + r.offset[0] / 64.0 + d * math.sin(a))
                y = round(y + r.offset[1] / 64.0 + d * math.cos(a))
                self._renderer.draw_text_image(r.image, x, y + 1, angle, gc)

        cls = TextRenderer
    _RENDERER.append(cls)
    return cls


def text_inches(labels, size: float) -> float:
    """Width in inches of the widest of labels at size pt, as the renderer lays it out (the
    texts are kept, `TEXTS`, so that drawing them later costs nothing more)."""
    from matplotlib.font_manager import FontProperties

    renderer = renderer_class()(1, 1, 72)
    prop = FontProperties(size=size)
    return max((renderer.get_text_width_height_descent(s, prop, False)[0] for s in labels
                if s), default=0.0) / 72.0
