"""The control surface and the rule-firing strip as images, and the operating point as
CSS: :func:`surface_grid` / :func:`surface_png` (crisp outputs over a plane of two
inputs, a heatmap), :func:`timeline_png` (which rules fired over the run),
:func:`marker_fraction` / :func:`marker_style` (the dot on the surfaces: the heatmaps are
sent once, only this moves; see :mod:`.surface_panel`)."""

from __future__ import annotations

import io
import math

import numpy as np


def surface_grid(fis, x_index, y_index, x_range, y_range, held, n: int = 41) -> tuple:
    """Evaluate ``fis`` on an n x n grid of inputs ``x_index`` and ``y_index`` with the
    other inputs at ``held`` (a full input vector). Returns (xs, ys, outputs (ny, nx, n_out))."""
    xs = np.linspace(*x_range, n)
    ys = np.linspace(*y_range, n)
    gx, gy = np.meshgrid(xs, ys)
    X = np.tile(np.asarray(held, dtype=float), (gx.size, 1))
    X[:, x_index] = gx.ravel()
    X[:, y_index] = gy.ravel()
    Y = fis.evaluate(X)
    return xs, ys, Y.reshape(n, n, -1)


def diverging_rgb(values: np.ndarray, limit: float) -> np.ndarray:
    """Blue (negative) - white - red (positive), symmetric about 0, for a heatmap."""
    t = np.clip(np.asarray(values, dtype=float) / max(limit, 1e-9), -1.0, 1.0)
    pos = np.array([220, 38, 38], float)
    neg = np.array([37, 99, 235], float)
    white = np.array([255, 255, 255], float)
    a = np.abs(t)[..., None]
    col = np.where(t[..., None] >= 0, white + a * (pos - white), white + a * (neg - white))
    col = np.where(np.isfinite(values)[..., None], col, 200.0)
    return col.astype(np.uint8)


def surface_png(values: np.ndarray, limit: float, scale: int = 4) -> bytes:
    """The heatmap (rows = y from the top, so flipped: +y up) as PNG bytes."""
    from PIL import Image

    rgb = diverging_rgb(values[::-1], limit)
    img = Image.fromarray(rgb, "RGB").resize(
        (rgb.shape[1] * scale, rgb.shape[0] * scale), Image.NEAREST
    )
    buf = io.BytesIO()
    img.save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def timeline_png(times, strengths, columns: int = 240, row_px: int = 3) -> bytes:
    """The rule-firing strip: a row per rule (rule 1 at the top), time to the right,
    each cell the strongest firing in its time bin (white 0 to orange 1)."""
    from PIL import Image

    n, n_rules = strengths.shape
    cols = max(1, min(columns, n))
    edges = np.linspace(0, n, cols + 1).astype(int)
    binned = np.zeros((n_rules, cols))
    for c in range(cols):
        a, b = edges[c], max(edges[c + 1], edges[c] + 1)
        binned[:, c] = strengths[a:b].max(axis=0)
    level = np.clip(binned, 0.0, 1.0)[..., None]
    white, orange = np.array([255.0, 255.0, 255.0]), np.array([234.0, 88.0, 12.0])
    rgb = (white + level * (orange - white)).astype(np.uint8)
    img = Image.fromarray(rgb, "RGB").resize((cols * 2, n_rules * row_px), Image.NEAREST)
    buf = io.BytesIO()
    img.save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def marker_fraction(value_x, value_y, x_range, y_range) -> tuple[float, float] | None:
    """Where the operating point sits on a heatmap, as fractions (left, top), or None
    when it is off the plane (an input not sensed)."""
    if not (math.isfinite(value_x) and math.isfinite(value_y)):
        return None
    fx = (value_x - x_range[0]) / (x_range[1] - x_range[0])
    fy = (value_y - y_range[0]) / (y_range[1] - y_range[0])
    return float(np.clip(fx, 0.0, 1.0)), float(np.clip(1.0 - fy, 0.0, 1.0))


def marker_style(markers: dict) -> str:
    """CSS that places each marker (element id -> (left, top) fractions or None)."""
    rules = []
    for element_id, where in markers.items():
        if where is None:
            rules.append(f"#{element_id}{{display:none!important}}")
        else:
            rules.append(
                f"#{element_id}{{display:block!important;left:{100 * where[0]:.1f}%;"
                f"top:{100 * where[1]:.1f}%}}"
            )
    return "<style>" + "".join(rules) + "</style>"
