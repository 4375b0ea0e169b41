"""The stages' progress bars (src/inpaint360gs/core/progress.py): the counts of a bar reach the
listener of the thread that made it, monotone up to the total, and no other thread's."""

from __future__ import annotations

import threading

from inpaint360gs.core.progress import current_listener, progress_listener, stage_bar, track


def test_a_thread_s_listener_gets_its_bar_s_counts_up_to_the_total_and_no_other_thread_s():
    got: dict[str, list] = {"a": [], "b": []}
    start = threading.Barrier(3)  # the three bars run at the same time

    def work(name: str, total: int) -> None:
        with progress_listener(lambda desc, done, tot: got[name].append((desc, done, tot))):
            start.wait()
            with stage_bar(total, f"bar {name}", enabled=False) as bar:
                for _ in range(total):
                    bar.update(1)
                    bar.set_postfix(x=1, refresh=False)

    def stranger() -> None:  # a thread without a listener: its bar goes nowhere
        start.wait()
        with stage_bar(50, "stranger", enabled=False) as bar:
            bar.update(50)

    threads = [threading.Thread(target=work, args=("a", 30)), threading.Thread(target=work, args=("b", 7)), threading.Thread(target=stranger)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for name, total in (("a", 30), ("b", 7)):
        seen = got[name]
        assert {d for d, _, _ in seen} == {f"bar {name}"} and {t for _, _, t in seen} == {total}
        done = [n for _, n, _ in seen]
        assert done == sorted(done) and done[0] == 0 and done[-1] == total
    assert current_listener() is None  # the block's listener was the threads', not this one's


def test_track_counts_each_item_after_its_body_and_the_listener_block_restores_the_outer_one():
    outer, inner = [], []
    with progress_listener(lambda *a: outer.append(a)):
        with progress_listener(lambda *a: inner.append(a)):
            for i, item in enumerate(track(["x", "y", "z"], "views", enabled=False)):
                assert inner[-1] == ("views", i, 3)  # the item's body runs before it is counted
        assert inner[-1] == ("views", 3, 3)
        bar = stage_bar(None, "open-ended", enabled=False, initial=5)
        bar.update(2)
        bar.close()
    assert outer == [("open-ended", 5, None), ("open-ended", 7, None)]
    assert current_listener() is None


def test_an_enabled_bar_writes_tqdm_s_line(capsys):
    with progress_listener(lambda *a: None):
        with stage_bar(4, "3DGS tiny", enabled=True) as bar:
            bar.update(4)
    err = capsys.readouterr().err
    assert "3DGS tiny" in err and "4/4" in err
