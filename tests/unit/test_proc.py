"""The runner's pure parts: the environment tools run in, and the error line picked from output."""

from __future__ import annotations

from uros_build.proc import messages_in_c


def test_messages_in_english_the_rest_of_the_locale_kept() -> None:
    spanish = {"LC_ALL": "es_ES.UTF-8", "LANGUAGE": "es", "PATH": "/bin"}
    assert messages_in_c(spanish) == {
        "LANG": "es_ES.UTF-8",  # character set, numbers, collation: still the user's
        "LANGUAGE": "es",  # ignored by gettext where LC_MESSAGES is C
        "LC_MESSAGES": "C",
        "PATH": "/bin",
    }
    assert messages_in_c({"LANG": "de_DE.UTF-8"}) == {"LANG": "de_DE.UTF-8", "LC_MESSAGES": "C"}
    assert messages_in_c({}) == {"LC_MESSAGES": "C"}
