"""Heat maps of sweep results, on synthetic results frames (no simulation)."""

import itertools
import json

import numpy as np
import pandas as pd
import pytest
from matplotlib.collections import QuadMesh
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure

from mfcontrol.experiments import maps

PNG = b"\x89PNG\r\n\x1a\n"
XS = np.logspace(-3, 0, 4)          # controller.alpha: 1e-3 .. 1, log-spaced
YS = np.linspace(0.0, 3.0, 3)       # plant.dR: 0, 1.5, 3 ohm, linear


def f(x, y):
    return 10.0 * x + y + 1.0       # known metric: positive, spans < 2 decades


def frame(xs=XS, ys=YS, metric=f, threshold=5.0, extra=None, diverge_above=np.inf):
    """A full-product results frame like results.parquet; stable = metric < threshold."""
    keys = {"controller.alpha": xs, "plant.dR": ys, **(extra or {})}
    rows = []
    for m, values in enumerate(itertools.product(*keys.values())):
        row = dict(zip(keys, values, strict=True))
        v = metric(row["controller.alpha"], row["plant.dR"])
        for k, val in (extra or {}).items():
            v += 100.0 * row[k] * (val.index(row[k]) if isinstance(val, list) else 0)
        diverged = v > diverge_above
        rows.append({**row, "iae": v, "ise": v * v, "max_abs_e": v / 2,
                     "diverged": diverged, "t_diverge": 0.01 if diverged else np.nan,
                     "n_samples": 100, "settled": bool(v < threshold and not diverged),
                     "member": m})
    return pd.DataFrame(rows)


def mesh_of(fig: Figure, i=0) -> QuadMesh:
    return [c for c in fig.axes[i].collections if isinstance(c, QuadMesh)][0]


def boundary_lines(ax):
    return [ln for ln in ax.get_lines() if ln.get_gid() == "settling-boundary"]


def hatched_cells(ax):
    hatch = [c for c in ax.collections if c.get_gid() == "unsettled-hatch"]
    return len(hatch[0].get_paths()) if hatch else 0


def legend_texts(ax):
    leg = ax.get_legend()
    return [t.get_text() for t in leg.get_texts()] if leg else []


def test_pivot_puts_each_value_in_its_cell():
    fig = maps.heatmap(frame(), "controller.alpha", "plant.dR", "iae")
    z = mesh_of(fig).get_array()
    assert z.shape == (YS.size, XS.size)          # rows = y, columns = x
    expected = f(XS[None, :], YS[:, None])
    np.testing.assert_allclose(np.ma.filled(z, np.nan), expected)


def test_pivot_does_not_depend_on_row_order():
    shuffled = frame().sample(frac=1.0, random_state=3)
    z = mesh_of(maps.heatmap(shuffled, "controller.alpha", "plant.dR", "iae")).get_array()
    np.testing.assert_allclose(np.ma.filled(z, np.nan), f(XS[None, :], YS[:, None]))


def test_swapping_axes_transposes_the_grid():
    z = mesh_of(maps.heatmap(frame(), "plant.dR", "controller.alpha", "iae")).get_array()
    np.testing.assert_allclose(np.ma.filled(z, np.nan), f(XS[:, None], YS[None, :]))


def test_log_axis_detection_and_edges():
    fig = maps.heatmap(frame(), "controller.alpha", "plant.dR", "iae")
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "linear"
    # geometric midpoints on the log axis, arithmetic ones on the linear axis
    coords = mesh_of(fig).get_coordinates()
    np.testing.assert_allclose(coords[0, :, 0], np.logspace(-3.5, 0.5, 5))
    np.testing.assert_allclose(coords[:, 0, 1], [-0.75, 0.75, 2.25, 3.75])
    assert maps.is_log_spaced([1e-3, 1e-2, 1e-1])
    assert not maps.is_log_spaced([1.0, 2.0, 3.0])
    assert not maps.is_log_spaced([-1.0, -10.0, -100.0])
    assert not maps.is_log_spaced([0.0, 1.0, 10.0])


def test_log_axes_can_be_forced_either_way():
    fig = maps.heatmap(frame(), "controller.alpha", "plant.dR", "iae", log_x=False)
    assert fig.axes[0].get_xscale() == "linear"
    fig = maps.heatmap(frame(ys=[1.0, 2.0, 3.0]), "controller.alpha", "plant.dR", "iae",
                       log_y=True)
    assert fig.axes[0].get_yscale() == "log"
    with pytest.raises(ValueError, match="positive"):
        maps.heatmap(frame(), "controller.alpha", "plant.dR", "iae", log_y=True)  # y has 0


def test_colour_scale_is_log_only_beyond_two_decades():
    lin = mesh_of(maps.heatmap(frame(), "controller.alpha", "plant.dR", "iae")).norm
    assert not isinstance(lin, LogNorm)
    wide = frame(metric=lambda x, y: 1e4 * x + y + 1.0)          # 1 .. 1e4
    log = mesh_of(maps.heatmap(wide, "controller.alpha", "plant.dR", "iae")).norm
    assert isinstance(log, LogNorm)


def test_colour_bar_and_axis_labels():
    fig = maps.heatmap(frame(extra={"sim.custom": [7.0]}), "controller.alpha", "plant.dR",
                       "iae")
    ax, cax = fig.axes
    assert ax.get_xlabel() == "ultra-local model gain alpha"
    assert ax.get_ylabel() == "load change dR (ohm)"
    assert cax.get_ylabel() == "IAE, the integral of |e| (output unit s)"  # no case known
    assert maps.axis_label("plant.dR") == "load change dR (ohm)"
    assert maps.axis_label("controller.Gamma") == "adaptation step Gamma"
    assert maps.axis_label("sim.custom") == "sim.custom"


def test_boundary_drawn_exactly_when_both_classes_exist():
    mixed = maps.heatmap(frame(threshold=5.0), "controller.alpha", "plant.dR", "iae")
    lines = boundary_lines(mixed.axes[0])
    assert lines and "boundary of the settled runs" in legend_texts(mixed.axes[0])
    assert "all settled" not in mixed.axes[0].get_title()
    # f >= 5 at x = 1 (3 cells) and at x = 0.1, y = 3 (1 cell): those are hatched
    assert hatched_cells(mixed.axes[0]) == 4
    assert "not settled" in legend_texts(mixed.axes[0])

    for threshold, words, hatched in ((1e9, "all settled", 0), (-1.0, "none settled", 12)):
        fig = maps.heatmap(frame(threshold=threshold), "controller.alpha", "plant.dR", "iae")
        assert boundary_lines(fig.axes[0]) == []
        assert "boundary of the settled runs" not in legend_texts(fig.axes[0])
        assert words in fig.axes[0].get_title()
        assert hatched_cells(fig.axes[0]) == hatched


def test_no_stable_column_no_boundary():
    fig = maps.heatmap(frame().drop(columns="settled"), "controller.alpha", "plant.dR", "iae")
    assert boundary_lines(fig.axes[0]) == [] and hatched_cells(fig.axes[0]) == 0
    assert "settled" not in fig.axes[0].get_title()


def test_boundary_runs_between_stable_and_unstable_cells():
    # stable exactly where x < 0.1: the boundary is the vertical line at the geometric
    # midpoint between 1e-2 and 1e-1, over the whole height of the map
    df = frame()
    df["settled"] = df["controller.alpha"] < 0.05
    fig = maps.heatmap(df, "controller.alpha", "plant.dR", "iae")
    (line,) = boundary_lines(fig.axes[0])
    np.testing.assert_allclose(line.get_xdata(), 10 ** -1.5)
    assert min(line.get_ydata()) == pytest.approx(-0.75)
    assert max(line.get_ydata()) == pytest.approx(3.75)


def test_where_selects_the_slice_of_a_third_key():
    df = frame(extra={"controller.kp": [1.0, 2.0]})
    with pytest.raises(ValueError, match=r"controller\.kp"):
        maps.heatmap(df, "controller.alpha", "plant.dR", "iae")
    for i, kp in enumerate([1.0, 2.0]):
        fig = maps.heatmap(df, "controller.alpha", "plant.dR", "iae",
                           where={"controller.kp": kp})
        z = np.ma.filled(mesh_of(fig).get_array(), np.nan)
        np.testing.assert_allclose(z, f(XS[None, :], YS[:, None]) + 100.0 * kp * i)
        assert "controller.kp = " in fig.axes[0].get_title()


def test_where_errors():
    df = frame(extra={"controller.kp": [1.0, 2.0]})
    with pytest.raises(ValueError, match="no member has controller.kp = 3"):
        maps.heatmap(df, "controller.alpha", "plant.dR", "iae", where={"controller.kp": 3.0})
    with pytest.raises(ValueError, match="not a column"):
        maps.heatmap(df, "controller.alpha", "plant.dR", "iae", where={"plant.L": 1.0})
    with pytest.raises(ValueError, match="axis of the map"):
        maps.heatmap(df, "controller.alpha", "plant.dR", "iae",
                     where={"controller.kp": 1.0, "plant.dR": 0.0})


def test_unknown_columns_are_errors_listing_the_allowed_ones():
    df = frame()
    with pytest.raises(ValueError, match=r"x = 'plant\.R'.*controller\.alpha.*plant\.dR"):
        maps.heatmap(df, "plant.R", "plant.dR", "iae")
    with pytest.raises(ValueError, match=r"y = 'iae' is not a swept key"):
        maps.heatmap(df, "controller.alpha", "iae", "iae")
    with pytest.raises(ValueError, match=r"metric = 'itea'.*'itae'|metric = 'itea'.*'iae'"):
        maps.heatmap(df, "controller.alpha", "plant.dR", "itea")


def test_diverged_members_are_grey_cells_and_in_the_legend():
    df = frame(diverge_above=12.0)        # x = 1 with y >= 1.5: 10 + y + 1 > 12
    fig = maps.heatmap(df, "controller.alpha", "plant.dR", "iae")
    mesh = mesh_of(fig)
    z = mesh.get_array()
    expected_nan = np.zeros((YS.size, XS.size), dtype=bool)
    expected_nan[1:, -1] = True
    np.testing.assert_array_equal(np.ma.getmaskarray(z), expected_nan)
    bad = np.asarray(mesh.cmap.get_bad())
    assert bad[3] == 1.0
    assert all(np.abs(bad[:3] - mesh.cmap(v)[:3]).max() > 0.1 for v in np.linspace(0, 1, 11))
    assert "diverged (2 of 12)" in legend_texts(fig.axes[0])


def test_nan_metric_is_a_grey_cell_too():
    df = frame()
    df.loc[0, "iae"] = np.nan
    z = mesh_of(maps.heatmap(df, "controller.alpha", "plant.dR", "iae")).get_array()
    assert np.ma.getmaskarray(z).sum() == 1


def test_t_diverge_is_not_hidden_for_diverged_members():
    df = frame(diverge_above=12.0)
    fig = maps.heatmap(df, "controller.alpha", "plant.dR", "t_diverge")
    z = mesh_of(fig).get_array()
    assert (~np.ma.getmaskarray(z)).sum() == 2
    assert "did not diverge (10 of 12)" in legend_texts(fig.axes[0])


def test_heatmap_draws_into_a_given_axes():
    fig = Figure()
    ax = fig.subplots()
    assert maps.heatmap(frame(), "controller.alpha", "plant.dR", "iae", ax=ax) is fig
    assert mesh_of(fig) in ax.collections


def test_side_by_side_shares_the_colour_norm(tmp_path, monkeypatch):
    a = frame()
    b = frame(metric=lambda x, y: 3.0 * f(x, y))
    captured = []
    orig = maps.save_figure

    def spy(fig, path):  # the figure as it is written
        captured.append(fig)
        return orig(fig, path)

    monkeypatch.setattr(maps, "save_figure", spy)
    out = maps.draw_maps_side_by_side([(a, "standard"), (b, "variational")],
                                      "controller.alpha", "plant.dR", "iae",
                                      tmp_path / "both.png")
    assert out.read_bytes().startswith(PNG)
    (fig,) = captured
    panels, colour_bar = fig.axes[:2], fig.axes[2:]
    assert [ax.get_title() for ax in panels] == ["standard", "variational"]
    assert len(colour_bar) == 1
    assert colour_bar[0].get_ylabel() == "IAE, the integral of |e| (output unit s)"
    norms = [mesh_of(fig, i).norm for i in range(2)]
    assert norms[0] is norms[1]
    # the stable members set the scale (found by the gallery: an unstable member's IAE of
    # 1e7 flattened every stable cell to one colour); the others are beyond its end
    stable = pd.concat([a, b]).query("settled")["iae"]
    assert (norms[0].vmin, norms[0].vmax) == pytest.approx((stable.min(), stable.max()))
    assert pd.concat([a, b])["iae"].max() > stable.max()
    assert mesh_of(fig, 1).colorbar.extend == "max"  # the bar says so with an arrow


def _write_sweep(folder, df):
    folder.mkdir()
    df.to_parquet(folder / "results.parquet")
    grid = {"controller.alpha": list(XS), "plant.dR": list(YS)}
    (folder / "sweep.json").write_text(json.dumps({"case": "tiny", "grid": grid}))


def test_draw_map_writes_a_png_from_a_sweep_folder(tmp_path):
    folder = tmp_path / "sweep"
    _write_sweep(folder, frame(diverge_above=12.0))
    out = maps.draw_map(folder, "controller.alpha", "plant.dR", "iae")
    assert out == folder / "map-iae-controller.alpha-plant.dR.png"
    data = out.read_bytes()
    assert data.startswith(PNG)
    assert 10_000 < len(data) < 2_000_000
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    assert (width, height) == (7 * 120, round(5.2 * 120))


def test_draw_map_explicit_path_and_where(tmp_path):
    folder = tmp_path / "sweep"
    _write_sweep(folder, frame(extra={"controller.kp": [1.0, 2.0]}))
    out = maps.draw_map(folder, "controller.alpha", "plant.dR", "ise",
                        where={"controller.kp": 2.0})
    assert out.name == "map-ise-controller.alpha-plant.dR-controller.kp=2.png"
    assert out.read_bytes().startswith(PNG)
    target = tmp_path / "elsewhere.png"
    assert maps.draw_map(folder, "controller.alpha", "plant.dR", "ise", path=target,
                         where={"controller.kp": 1.0}) == target
    assert target.read_bytes().startswith(PNG)


def test_load_reads_results_and_sweep_json(tmp_path):
    folder = tmp_path / "sweep"
    df = frame()
    _write_sweep(folder, df)
    back = maps.load(folder)
    pd.testing.assert_frame_equal(back, df)
    assert back.attrs["sweep"]["case"] == "tiny"


def test_a_results_file_from_before_the_rename_is_hatched_as_it_was(tmp_path):
    # its column was `stable`: read as `settled`, its map keeps its hatching and boundary
    folder = tmp_path / "old"
    _write_sweep(folder, frame(threshold=5.0).rename(columns={"settled": "stable"}))
    back = maps.load(folder)
    assert "settled" in back.columns and "stable" not in back.columns
    fig = maps.heatmap(back, "controller.alpha", "plant.dR", "iae")
    assert hatched_cells(fig.axes[0]) == 4 and boundary_lines(fig.axes[0])


def test_load_without_results_is_a_clear_error(tmp_path):
    with pytest.raises(ValueError, match="no results.parquet"):
        maps.load(tmp_path)


def test_the_colour_bar_and_title_say_the_metric_in_words_with_its_unit(tmp_path):
    """They said `max_abs_e` (issue 15). Units from the case of a sweep folder, or given."""
    fig = maps.heatmap(frame(), "controller.alpha", "plant.dR", "max_abs_e", units=("V", "1"))
    assert fig.axes[-1].get_ylabel() == "largest |e| after the settling time (V)"
    assert fig.axes[0].get_title().startswith("largest |e| after the settling time over")
    f = frame()
    f.attrs["sweep"] = {"case": "motor-noise-ipi", "overrides": {}}
    fig = maps.heatmap(f, "controller.alpha", "plant.dR", "iae")
    assert fig.axes[-1].get_ylabel() == "IAE, the integral of |e| (rad)"  # not "rad/s s"
    fig = maps.heatmap(frame(), "controller.alpha", "plant.dR", "ise")  # no case known
    assert fig.axes[-1].get_ylabel() == "ISE, the integral of e^2 ((output unit)^2 s)"


def test_maps_of_divergence_columns_and_of_unstable_non_positive_values():
    """Found in review. A map of `stable` took its scale from the stable members only
    (0.5 to 1.5, an arrow at the bottom); a log scale chosen from the stable members'
    values masked an unstable member's value <= 0, which was then painted the grey that
    means 'diverged'."""
    fig = maps.heatmap(frame(), "controller.alpha", "plant.dR", "settled")
    norm = mesh_of(fig).norm
    assert (norm.vmin, norm.vmax) == (0.0, 1.0)

    def spread(x, y):  # stable members span 4 decades; unstable ones go to zero and below
        return 10.0 ** (4 * x / XS[-1]) if y < 2 else -1.0
    f = frame(metric=spread, threshold=1e9)
    f.loc[f["plant.dR"] >= 2, "settled"] = False
    norm = mesh_of(maps.heatmap(f, "controller.alpha", "plant.dR", "iae")).norm
    assert not isinstance(norm, LogNorm) and norm.vmin > 0  # linear, stable members' range
