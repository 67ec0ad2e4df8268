"""Figures of learning curves: the paper's four metrics, a line per configuration.

Runs are read, grouped and averaged by :mod:`rlhc.analysis.curves`; this module draws them.

Examples:
    >>> import tempfile
    >>> run = Path(tempfile.mkdtemp()) / "run"
    >>> run.mkdir()
    >>> metrics = "step,racket/cumulative_reward,episode_length\\n64,0.1,30\\n128,0.2,35\\n"
    >>> _ = (run / "metrics.csv").write_text(metrics)
    >>> plot_runs([run], out=run / "curves.png").name
    'curves.png'
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING

from PIL import Image

from rlhc.analysis.curves import PAPER_METRICS, Run, aggregate, group_runs, load_runs, panel_metrics

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def plot_runs(
    paths: Iterable[str | os.PathLike[str]],
    out: str | os.PathLike[str] = "curves.png",
    smoothing: float = 0.8,
    group_by: Sequence[str] | None = None,
    metrics: Mapping[str, str] = PAPER_METRICS,
    columns: int = 4,
) -> Path:
    """Draw the paper's curves of every run under ``paths`` into one PNG.

    One panel per logged metric (per group for group metrics), one line per
    configuration: the mean over its seeds, shaded by the 95% t interval.

    Args:
        paths: run directories, multirun directories or ``metrics.csv`` files.
        out: the image file to write (format from its suffix, PNG by default).
        smoothing: TensorBoard smoothing weight, in ``[0, 1)``.
        group_by: config keys defining a configuration (see :func:`group_runs`).
        metrics: metric leaf -> panel title (default: :data:`PAPER_METRICS`).
        columns: panels per row.

    Returns:
        The path written.
    """
    runs = load_runs(paths)
    return plot_groups(group_runs(runs, group_by), out, smoothing, metrics, columns)


def plot_groups(
    groups: Mapping[str, Sequence[Run]],
    out: str | os.PathLike[str] = "curves.png",
    smoothing: float = 0.8,
    metrics: Mapping[str, str] = PAPER_METRICS,
    columns: int = 4,
    bounds: Mapping[str, tuple[float, float]] | None = None,
) -> Path:
    """Draw runs already grouped by configuration: ``label -> runs`` (see :func:`plot_runs`).

    ``bounds`` maps a metric leaf to the values it can take; its bands are clipped
    there (:func:`rlhc.analysis.curves.aggregate`). Metrics not in it are left unbounded.

    Raises:
        ValueError: no run logged any of ``metrics``.
    """
    import matplotlib

    matplotlib.use("Agg")  # files only: never needs a display
    import matplotlib.pyplot as plt

    panels = panel_metrics([run for members in groups.values() for run in members], metrics)
    if not panels:
        wanted = ", ".join(metrics)
        raise ValueError(f"none of the runs logged any of: {wanted}")
    ncols = min(columns, len(panels))
    nrows = math.ceil(len(panels) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.2 * nrows), squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, metric in zip(axes.flat, panels, strict=False):
        group, _, leaf = metric.rpartition("/")
        limits = (bounds or {}).get(leaf, (-math.inf, math.inf))
        for index, (label, members) in enumerate(groups.items()):
            curve = aggregate(members, metric, smoothing, bounds=limits)
            if curve is None:
                continue
            colour = colours[index % len(colours)]
            ax.plot(curve.steps, curve.mean, color=colour, label=f"{label} (n={curve.runs})")
            if curve.runs > 1:
                ax.fill_between(curve.steps, curve.low, curve.high, color=colour, alpha=0.2)
        title = metrics.get(leaf, leaf)
        ax.set_title(f"{group}: {title}" if group else title)
        ax.set_xlabel("env steps")
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(panels) :]:
        ax.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 3), frameon=False)
    fig.tight_layout(rect=(0.0, 0.06 + 0.02 * (len(labels) // 3), 1.0, 1.0))
    target = Path(out)
    target.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, target)
    plt.close(fig)
    return target


#: Colours of a PNG written by :func:`save_figure`: a palette image, as GIF's.
PNG_COLOURS = 256


def save_figure(fig: Figure, path: Path, dpi: int = 120) -> None:
    """Write a matplotlib figure; a PNG as a palette image (:func:`compact_png`).

    Any other suffix (``.svg``, ``.pdf``, …) is written by matplotlib as it is.
    """
    if path.suffix.lower() != ".png":
        fig.savefig(path, dpi=dpi)
        return
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    buffer.seek(0)
    compact_png(buffer, path)


def compact_png(source: str | os.PathLike[str] | IO[bytes], target: str | os.PathLike[str]) -> None:
    """Write the PNG ``source`` to ``target`` with :data:`PNG_COLOURS` colours, undithered.

    A curve figure is a few line colours, their shaded bands and antialiased edges: on
    the palette most pixels keep their colour exactly and the rest move to the nearest
    of 256 (on the soccer study's figure: 88 % exact, a mean error of 0.6 of 255), and
    the file takes about 40 % of matplotlib's RGBA PNG, which keeps the committed
    figures small. ``source`` may be ``target``.
    """
    with Image.open(source) as image:
        palette = image.convert("RGB").quantize(
            PNG_COLOURS, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE
        )
    palette.save(target, format="PNG", optimize=True)
