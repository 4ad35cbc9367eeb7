"""animation.gif: the mechanism moving over the run, blitted frames on one palette; and
animation.mp4 of the same frames where ffmpeg is installed (`write_animations`)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

from .clearance import nearest_row, notable
from .plane import Drawing, fit_legend, mark_approaches, plane_figure
from .render import renderer_class
from .scene import Scene
from .style import ANIM_DPI, ANIM_FPS, ANIM_FRAMES, CROWD, FONT, styled, text_width

HOLD = 1.0          # seconds the animation stays on a closest approach


def write_animation(cm, data, out: Path, fps: int | None = None,
                    width: int | None = None, minima=()) -> Path:
    """Write out/animation.gif (see `_animate`); returns its path."""
    return _animate(cm, data, out, fps, width, mp4=False, minima=minima)[0]


def write_animations(cm, data, out: Path, fps: int | None = None,
                     width: int | None = None, minima=()) -> tuple[list[Path], list[str]]:
    """Write out/animation.gif and, where ffmpeg is installed, out/animation.mp4 of the same
    frames (matplotlib's FFMpegWriter, H.264). Returns (the files written, notes): a note says
    why the MP4 was not written (no ffmpeg, or ffmpeg failed); that is not an error, the GIF
    is there."""
    why = mp4_missing()
    gif, failed = _animate(cm, data, out, fps, width, mp4=why is None, minima=minima)
    why = why or failed
    if why is None:
        return [gif, gif.with_suffix(".mp4")], []
    return [gif], [f"animation.mp4 was not written: {why}; animation.gif has the frames"]


def mp4_missing() -> str | None:
    """Why animation.mp4 cannot be written here (None: it can): matplotlib finds no ffmpeg."""
    import matplotlib as mpl
    from matplotlib.animation import writers
    if writers.is_available("ffmpeg"):
        return None
    return (f"ffmpeg was not found (matplotlib's animation.ffmpeg_path is "
            f"{mpl.rcParams['animation.ffmpeg_path']!r}): install ffmpeg")


@styled
def _animate(cm, data, out: Path, fps: int | None, width: int | None,
             mp4: bool, minima=()) -> tuple[Path, str | None]:
    """Write out/animation.gif: the mechanism moving over the run (bodies in their plot colours,
    joint and point paths growing), up to ANIM_FRAMES frames at fps frames per second (default
    ANIM_FPS), width pixels wide (default 640; the height follows the drawing, the legend
    beside it is never cut: the image widens for it).

    Frames are blitted: the axes, ground and legend are rendered once, each frame redraws only
    the moving artists on that background (a full matplotlib redraw per frame costs ten times
    more), and every frame is mapped onto one shared palette before Pillow writes the GIF.

    minima: each pair of shapes' closest approach (a, b, t, d, pa, pb, user units; limit where
    known: `planarkin.clearance.cycle.minima`): the frame nearest the least of them and those
    closer than their limit (`clearance.notable`) is added, marked (`clearance.mark_closest`)
    and held for HOLD seconds.

    mp4: also write out/animation.mp4 from the same frames (`_write_mp4`). Returns the GIF's
    path and why the MP4 is missing (None: written, or not asked for)."""
    from matplotlib.animation import PillowWriter
    from PIL import Image

    path = Path(out) / "animation.gif"
    scene = Scene(cm, data)
    N = len(data.t)
    rows = np.unique(np.linspace(0, max(N - 1, 0), min(ANIM_FRAMES, max(N, 1))).round().astype(int))
    fps = int(fps or ANIM_FPS)
    holds = _holds(data.t, minima) if N else {}
    rows = np.unique(np.r_[rows, list(holds)]).astype(int)
    fig, ax, beside = plane_figure(cm, scene, (width or 640) / ANIM_DPI,
                                    0.7 + text_width(cm.body_names), dpi=ANIM_DPI)
    # the named points' and the joints' paths one line each, the crowd's one collection
    npts = len(cm.point_names)
    own = [k for k in range(len(scene.traces)) if not scene.named <= k < npts]
    traces = [ax.plot([], [], color=scene.trace_styles[k][2], lw=scene.trace_styles[k][3],
                      zorder=5)[0] for k in own]
    crowd = None
    if npts > scene.named:
        from matplotlib.collections import LineCollection
        crowd = LineCollection([], colors=CROWD, linewidths=0.6, zorder=4.5)
        ax.add_collection(crowd, autolim=False)
        traces.append(crowd)
    drawing = Drawing(ax, scene, rows[-1], body_colors=True, zorder=10)
    stamp = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=FONT,
                    bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="none", alpha=0.8),
                    zorder=30)
    legend = fig.legend(handles=drawing.legend_handles(), loc="upper left",
                        bbox_to_anchor=beside, fontsize=FONT, frameon=False)
    fit_legend(fig, legend, ax, beside)
    ax.set_title(f"{cm.spec.name}: motion", fontsize=11, y=1.0)
    moving = traces + drawing.artists + [stamp]
    for a in moving:
        a.set_animated(True)
    w, h = (int(round(v * ANIM_DPI)) for v in fig.get_size_inches())
    renderer = renderer_class()(w, h, ANIM_DPI)
    fig.draw(renderer)                      # everything that does not move
    background = renderer.copy_from_bbox(fig.bbox)
    # the marks of the closest approaches (the axes' limits are final now), shown at their
    # frames only
    marks = {r: mark_approaches(ax, scene, ms, animated=True) for r, ms in holds.items()}
    moving += [a for v in marks.values() for a in v]

    def render(i) -> "Image.Image":
        for r, artists in marks.items():
            for a in artists:
                a.set_visible(r == i)
        drawing.set_row(i)
        for line, k in zip(traces, own):
            xy = scene.traces[k]
            line.set_data(xy[: i + 1, 0], xy[: i + 1, 1])
        if crowd is not None:
            crowd.set_segments(scene.crowd(i))
        stamp.set_text(f"t = {data.t[i]:.4g} s" + ("   closest approach" if i in marks
                                                     else ""))
        renderer.restore_region(background)
        for a in moving:
            a.draw(renderer)
        return Image.frombuffer("RGBA", (w, h), renderer.buffer_rgba(), "raw", "RGBA", 0,
                                1).convert("RGB")

    class BlitWriter(PillowWriter):
        """PillowWriter whose frames come from render(); one palette for the whole GIF (taken
        from the last frame, where every path is complete, and the held ones)."""

        def setup(self, fig, outfile, dpi=None):
            super().setup(fig, outfile, dpi=dpi)
            self.images = []
            self.repeat = []            # each frame's length, in frames of 1/fps s
            self.held = []

        def grab_frame(self, **savefig_kwargs):
            self.images.append(render(self.row))
            self.held.append(self.row in holds)
            self.repeat.append(max(1, round(HOLD * self.fps)) if self.held[-1] else 1)

        def finish(self):
            dither = Image.Dither.NONE
            palette = _palette_source(self.images, self.held).quantize(
                255, method=Image.Quantize.MEDIANCUT, dither=dither)
            # Pillow maps colours to the palette through a cache of 4-level cells: white
            # would become a near-white neighbour, so those all become white
            colors = np.array(palette.getpalette(), dtype=np.uint8).reshape(-1, 3)
            colors[colors.min(axis=1) >= 248] = 255
            palette.putpalette(colors.ravel().tolist())
            frames = [im.quantize(palette=palette, dither=dither) for im in self.images]
            ms = int(1000 / self.fps)
            duration = ms if not holds else [ms * self.repeat[k] for k in range(len(frames))]
            frames[0].save(self.outfile, save_all=True, append_images=frames[1:],
                           duration=duration, loop=0)

    writer = BlitWriter(fps=fps)
    writer.setup(fig, path, ANIM_DPI)       # (not writer.saving(): it changes rcParams)
    for i in rows:
        writer.row = i
        writer.grab_frame()
    writer.finish()
    # the MP4 at a fixed rate: a held frame repeated
    images = [im for im, k in zip(writer.images, writer.repeat) for _ in range(k)]
    return path, (_write_mp4(images, fig, path.with_suffix(".mp4"), fps) if mp4 else None)


def _palette_source(images, held):
    """The image the GIF's palette is taken from: the last frame, where every path is complete,
    and below it the held frames (held: a flag per frame; their marks' red is in no other
    frame)."""
    from PIL import Image

    held = [images[-1]] + [im for im, h in zip(images, held) if h]
    if len(held) == 1:
        return held[0]
    source = Image.new("RGB", (held[0].width, held[0].height * len(held)))
    for k, im in enumerate(held):
        source.paste(im, (0, k * im.height))
    return source


def _holds(t, minima) -> dict:
    """{row: [minima]}: the row nearest each closest approach worth marking
    (`clearance.notable`), to hold."""
    out = {}
    for m in notable(minima):
        out.setdefault(nearest_row(t, m.t), []).append(m)
    return out


def _write_mp4(images, fig, path: Path, fps: int) -> str | None:
    """Write the RGB frames `images` to path as H.264 through matplotlib's FFMpegWriter (frames
    piped as raw RGBA, padded with white to even sizes, which yuv420p needs). Returns None, or
    why there is no file (ffmpeg failed: a partial file is removed). ffmpeg never outlives this
    call, whatever stops it."""
    from matplotlib.animation import FFMpegWriter
    from PIL import Image

    w, h = images[0].size
    size = (w + w % 2, h + h % 2)

    class FrameWriter(FFMpegWriter):
        """FFMpegWriter fed with our frames, not with the figure's canvas (whose size it would
        change to even pixels)."""
        frame_size = size

        def _adjust_frame_size(self):
            return size[0] / self.dpi, size[1] / self.dpi

        def grab_frame(self, **savefig_kwargs):
            frame = Image.new("RGBA", size, "white")
            frame.paste(self.image, (0, 0))
            self._proc.stdin.write(frame.tobytes())

    # no encoder version in the file: the same frames give the same bytes
    writer = FrameWriter(fps=fps, codec="h264", extra_args=["-fflags", "+bitexact"])
    writer._proc = None
    try:
        writer.setup(fig, path, ANIM_DPI)
        for im in images:
            writer.image = im
            writer.grab_frame()
        writer.finish()
    except (OSError, subprocess.CalledProcessError) as e:
        path.unlink(missing_ok=True)
        err = (getattr(e, "stderr", None) or "").strip().splitlines()
        return f"ffmpeg failed: {err[-1] if err else e}"
    finally:
        proc = writer._proc
        if proc is not None and proc.poll() is None:     # stopped between two frames
            proc.kill()
            proc.communicate()
            path.unlink(missing_ok=True)
    return None


