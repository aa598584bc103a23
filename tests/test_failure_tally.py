"""The failed-runs table tallies runs by the kind of reason, not by per-run details."""

from uqguide.core.failures import reason_kind, reason_rows


def test_runs_failing_alike_in_their_own_work_folders_are_one_row():
    same = [f"the command exited with status 1; work folder kept: /tmp/w/call-{i}; last line "
            f"of stderr: 'diverged'" for i in range(20)]
    once = "model call crashed (work folder kept: /tmp/w/z)"
    rows = reason_rows("mc", 100, same + ["non-finite output value"] * 3 + [once])
    assert [r["count"] for r in rows] == [20, 3, 1]
    assert rows[0]["failed"] == "24"
    assert rows[0]["reason"] == ("the command exited with status 1; work folder kept: one per "
                                 "run; last line of stderr: 'diverged' (first: /tmp/w/call-0)")
    assert rows[2]["reason"] == once  # alone, shown as it is
    # what differs beyond the folder still tells the reasons apart
    assert reason_kind(same[0].replace("status 1", "status 2")) != reason_kind(same[1])
