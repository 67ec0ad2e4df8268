"""Figures of learning curves: the paper's four metrics, a line per configuration.

Runs are read, grouped and averaged by :mod:`rlhc.analysis.curves`; this module draws them.

Examples:
    >>> import tempfile
    >>> import numpy as np
    >>> steps = np.array([64.0, 128.0])
    >>> run = Run(Path("run"), {"step": steps, "episode_length": np.array([30.0, 35.0])})
    >>> out = Path(tempfile.mkdtemp()) / "curves.png"
    >>> plot_groups({"runs": [run]}, out).name
    'curves.png'
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING

from PIL import Image

from rlhc.analysis.curves import PAPER_METRICS, Run, aggregate, panel_metrics

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def plot_groups(
    groups: Mapping[str, Sequence[Run]],
    out: str | os.PathLike[str] = "curves.png",
    smoothing: float = 0.8,
    metrics: Mapping[str, str] = PAPER_METRICS,
    columns: int = 4,
    bounds: Mapping[str, tuple[float, float]] | None = None,
) -> Path:
    """Draw the curves of runs grouped by configuration (``label -> runs``) into one image.

    One panel per logged metric (per group for group metrics), one line per
    configuration: the mean over its runs, shaded by the 95% t interval.

    Args:
        groups: :func:`~rlhc.analysis.curves.group_runs`.
        out: the image file to write (format from its suffix).
        smoothing: TensorBoard smoothing weight, in ``[0, 1)``.
        metrics: metric leaf -> panel title.
        columns: panels per row.
        bounds: metric leaf -> the values it can take (its bands are clipped there).

    Returns:
        The path written.

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

    A curve figure is a few colours and their blends: most pixels keep their colour and
    the file takes about 40 % of matplotlib's RGBA PNG. ``source`` may be ``target``.
    """
    with Image.open(source) as image:
        palette = image.convert("RGB").quantize(
            PNG_COLOURS, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE
        )
    palette.save(target, format="PNG", optimize=True)
