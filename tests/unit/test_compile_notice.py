"""The first-compile notice says what happens next: the other commands' kernels compiled in the background, or not."""
from __future__ import annotations

import pytest

from bhr.cli import _progress
from bhr.warmup import BACKGROUND_ENV


@pytest.mark.parametrize("value", ["", "0"])
def test_notice_promises_the_background_compile_only_when_it_is_on(monkeypatch, value):
    monkeypatch.setenv(BACKGROUND_ENV, value)
    text = _progress.compile_notice()
    assert "the other commands are compiled in the background" in text and f"{BACKGROUND_ENV}=1 turns that off" in text


@pytest.mark.parametrize("value", ["1", "yes"])
def test_notice_with_the_background_compile_off_says_other_commands_compile_their_own(monkeypatch, value):
    monkeypatch.setenv(BACKGROUND_ENV, value)
    text = _progress.compile_notice()
    assert "the other commands are compiled in the background" not in text
    assert "nothing is compiled in the background" in text and "python -m bhr.warmup" in text
    assert text.startswith("Compiling bhr's kernels for this machine; this happens once")
