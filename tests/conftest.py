"""Shared pytest configuration."""

from __future__ import annotations

import os

# Rendering and loggers must never need a screen or the network in tests.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("WANDB_MODE", "offline")
os.environ.setdefault("MPLBACKEND", "Agg")
