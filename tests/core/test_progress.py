"""The terminal progress bar and its Ctrl-C handling (core/progress.py), which the command line
and scripts/factor_scene.py share: each keeps the output it had before the merge."""

from __future__ import annotations

import io
import signal

import pytest

from spectral_materials.core import progress as progress_module
from spectral_materials.core.errors import Cancelled
from spectral_materials.core.progress import (
    STAGE_STYLE,
    TerminalProgress,
    ctrl_c_cancels,
    report,
    scaled,
)


class Stream(io.StringIO):
    def __init__(self, tty: bool):
        super().__init__()
        self.tty = tty

    def isatty(self) -> bool:
        return self.tty


@pytest.fixture
def clock(monkeypatch):
    now = [100.0]
    monkeypatch.setattr(progress_module.time, "monotonic", lambda: now[0])
    return now


def test_script_style_not_a_terminal_writes_a_line_per_tenth():
    stream = Stream(tty=False)
    bar = TerminalProgress(stream)
    for fraction in (0.0, 0.05, 0.12, 0.19, 0.5, 1.0):
        assert bar(fraction, "factoring") is False
    assert stream.getvalue() == ("  0.0% factoring\n 12.0% factoring\n 50.0% factoring\n"
                                 "100.0% factoring\n")


def test_script_style_on_a_terminal_draws_a_fixed_width_bar():
    stream = Stream(tty=True)
    bar = TerminalProgress(stream)
    bar(0.5, "basis")
    bar(1.0, "done")
    assert stream.getvalue() == ("\r[###############...............]  50.0% basis" + " " * 55
                                 + "\r[##############################] 100.0% done" + " " * 56
                                 + "\n")


def test_cli_style_not_a_terminal_writes_a_line_per_stage():
    stream = Stream(tty=False)
    bar = TerminalProgress(stream, style=STAGE_STYLE)
    for fraction, message in ((0.0, "tabulating"), (0.4, "tabulating"), (0.5, "factoring"),
                              (1.0, "factoring")):
        bar(fraction, message)
    bar.info("a note")
    bar(1.0, "factoring")        # after other output the stage is named again
    assert stream.getvalue() == "tabulating...\nfactoring...\na note\nfactoring...\n"


def test_cli_style_on_a_terminal_redraws_ten_times_a_second_and_blanks_longer_lines(clock):
    stream = Stream(tty=True)
    bar = TerminalProgress(stream, style=STAGE_STYLE)
    bar(0.1, "a longer message")
    clock[0] += 0.05
    bar(0.2, "a longer message")  # too soon: not redrawn
    bar(0.2, "short")             # a new message: drawn at once, over the longer line
    bar.clear()
    assert stream.getvalue() == ("\r[###...........................]  10% a longer message"
                                 "\r[######........................]  20% short" + " " * 11
                                 + "\r" + " " * 43 + "\r")


def test_quiet_draws_nothing_but_still_answers_interrupted():
    stream = Stream(tty=True)
    bar = TerminalProgress(stream, quiet=True, style=STAGE_STYLE)
    assert bar(0.5, "x") is False
    bar.info("hidden")
    bar.interrupted = True
    assert bar(0.6, "x") is True
    with pytest.raises(Cancelled):
        bar.check()
    assert stream.getvalue() == ""


def test_report_and_scaled():
    seen = []
    callback = scaled(lambda f, m: seen.append((f, m)) or f > 0.75, 0.5, 1.0)
    report(callback, 2.0 / 5.0, "half")
    assert seen == [(0.7, "half")]
    with pytest.raises(Cancelled, match="late"):
        report(callback, 0.9, "late")
    report(None, 0.5, "nobody listens")
    assert scaled(None, 0.0, 1.0) is None


def test_first_ctrl_c_asks_to_stop_the_second_interrupts():
    bar = TerminalProgress(Stream(tty=False), quiet=True)
    before = signal.getsignal(signal.SIGINT)
    with ctrl_c_cancels(bar):
        signal.raise_signal(signal.SIGINT)
        assert bar.interrupted and bar(0.5, "x") is True
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(signal.SIGINT)
    assert signal.getsignal(signal.SIGINT) is before
