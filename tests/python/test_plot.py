"""The matplotlib helpers draw the result's own numbers: the path, each coordinate against t and
the residual history."""
import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import pardel  # noqa: E402
import pardel.plot  # noqa: E402


def test_plots_draw_the_result(spring_lag, tmp_path):
    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=2.0, N=30, method="jacobi-newton")
    ax = pardel.plot.path(r)
    x, y = ax.lines[0].get_data()
    np.testing.assert_array_equal(x, r.q[:, 0])
    np.testing.assert_array_equal(y, r.q[:, 1])
    ax.figure.savefig(tmp_path / "path.png")
    assert (tmp_path / "path.png").stat().st_size > 1000

    ax = pardel.plot.coordinates(r)
    assert [line.get_label() for line in ax.lines] == ["x", "y"]
    np.testing.assert_array_equal(ax.lines[1].get_data()[0], r.t)

    for draw in (pardel.plot.path, pardel.plot.coordinates, pardel.plot.convergence):
        with pytest.raises(TypeError, match=r"^pardel\.plot\.%s: ax must be a matplotlib Axes or None, got int 5$"
                           % draw.__name__):
            draw(r, ax=5)

    ax = pardel.plot.convergence(r)
    iterations, residuals = ax.lines[0].get_data()
    assert len(iterations) == np.count_nonzero(r.history["residual"] > 0)
    assert ax.get_yscale() == "log"
