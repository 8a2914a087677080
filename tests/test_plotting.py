"""Figure output: atomic writes (a failed save keeps the previous file, leaves no temporary)."""

import pytest

from bayes_emt.plotting import save_figure


def test_save_figure_is_atomic_and_closes(tmp_path):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    path = save_figure(fig, tmp_path / "a.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not plt.fignum_exists(fig.number)
    before = path.read_bytes()

    class Boom(RuntimeError):
        pass

    bad, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])

    def explode(*a, **k):
        raise Boom("disk full")

    bad.savefig = explode
    # a failed write names the target and says the earlier file is intact (_atomic, issue 24)
    with pytest.raises(OSError, match=r"a\.png: cannot write: disk full \(the previous a\.png is "):
        save_figure(bad, path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png"]
    assert not plt.fignum_exists(bad.number)
