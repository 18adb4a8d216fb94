"""Figures draw what is path: a program's rapids between cuts are not drawn as feed moves."""

from __future__ import annotations

import numpy as np

from fuzzyfeed.geometry.sampling import samples_from_points


def test_colored_path_leaves_out_jumps_between_pieces():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fuzzyfeed.report.plot import colored_path

    a = samples_from_points(np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]]))
    b = samples_from_points(np.array([[50.0, 50.0], [60.0, 50.0]]))
    # two cuts end to end as a program's plot joins them: arc length runs on, the tool jumps
    xyz = np.vstack([a.xyz, b.xyz])
    s = np.concatenate([a.s, b.s + a.s[-1]])
    joined = samples_from_points(xyz[:, :2])
    joined = type(joined)(u=s / s[-1], xyz=xyz, s=s, tangent=np.vstack([a.tangent, b.tangent]),
                          curvature=np.zeros(len(s)), d1=joined.d1, d2=joined.d2, dim=2)
    fig, ax = plt.subplots()
    colored_path(ax, joined, np.arange(len(s), dtype=float), "feed")
    drawn = ax.collections[0].get_segments()
    plt.close(fig)
    assert len(drawn) == 3                       # 2 + 1 segments, not the 40 mm jump
    assert all(np.linalg.norm(seg[1] - seg[0]) <= 10.0 + 1e-9 for seg in drawn)
