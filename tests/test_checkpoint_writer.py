"""The background checkpoint writer: items written in the order given, its first error raised
on the driver's thread, nothing written after it."""

from __future__ import annotations

import threading

import pytest

from uqguide.driver.run_folder import CheckpointWriter


def test_items_are_written_in_order_on_another_thread():
    written: list[tuple[int, str]] = []
    writer = CheckpointWriter(lambda i: written.append((i, threading.current_thread().name)),
                              maxsize=2)
    for i in range(10):
        writer.put(i)
    writer.flush()
    assert [i for i, _ in written] == list(range(10))
    assert {name for _, name in written} == {"uqguide-checkpoint"}
    writer.close()
    writer.close()  # a second close finds no thread to end


def test_the_first_error_is_raised_once_and_later_items_are_dropped():
    written: list[int] = []

    def write(i: int) -> None:
        if i == 2:
            raise OSError(28, "No space left on device")
        written.append(i)

    writer = CheckpointWriter(write)
    for i in range(5):
        writer.put(i)
    with pytest.raises(OSError, match="No space left"):
        writer.flush()
    assert written == [0, 1]  # 3 and 4 were queued after the failure: re-run on resume
    writer.flush()  # raised once, not again
    writer.close()


def test_drain_waits_for_the_queue_and_raises_nothing():
    def write(i: int) -> None:
        raise RuntimeError("broken")

    writer = CheckpointWriter(write)
    writer.put(0)
    writer.drain()
    with pytest.raises(RuntimeError, match="broken"):
        writer.close()
