"""The sketch recognizer's entry point (group `grammarkit`): `grammarkit recognize`,
`grammarkit sketch-session` and `grammarkit train sketch`.

Light on purpose: the plugin manager imports this module for every `grammarkit` command, so
only click is imported; torch, scipy and the renderer load when a command runs.
"""
from __future__ import annotations

from grammarkit import hookimpl

from .cli import recognize_command, sketch_session_command, train_sketch_command


@hookimpl
def grammarkit_cli_commands():
    return [recognize_command, sketch_session_command]


@hookimpl
def grammarkit_train_commands():
    return [train_sketch_command]
