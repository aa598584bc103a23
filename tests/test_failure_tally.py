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


def test_the_one_line_summary_counts_as_the_table_does():
    """stderr, the error of max_failed_fraction and the report said 67 aborts in 67 work
    folders as 67 reasons of count 1 (one 8.7 kB line), and cut the timeouts off."""
    from uqguide.core.failures import reason_summary

    aborts = [f"the command died of signal 6 (SIGABRT); work folder kept: /tmp/w/call-{i}"
              for i in range(67)]
    timeouts = ["timed out after 60 s"] * 2
    others = [f"reason {k}" for k in range(6)]
    assert reason_summary(aborts + timeouts, limit=2) == (
        "the command died of signal 6 (SIGABRT); work folder kept: one per run (first: "
        "/tmp/w/call-0) (67); timed out after 60 s (2)")
    line = reason_summary(aborts + timeouts + others, limit=3)
    assert line.endswith("; 5 other reasons (5)") and line.count(";") == 4
