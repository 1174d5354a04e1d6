"""Our defaults for Taichi's own settings (melange_ti.runtime.taichi_defaults): the kernel
cache's cap and Taichi's control-flow passes, and a user's own ``TI_`` variables winning
over them (docs/performance.md, "Compiling")."""

from __future__ import annotations

import os

import taichi as ti

from melange_ti import runtime

KEYS = ("TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES", "TI_CFG_OPTIMIZATION")


def test_our_defaults_give_way_to_the_users_own_variables(monkeypatch):
    for key in KEYS:
        monkeypatch.delenv(key, raising=False)
    assert runtime.taichi_defaults() == {"TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES": str(1 << 30), "TI_CFG_OPTIMIZATION": "0"}
    monkeypatch.setenv("TI_CFG_OPTIMIZATION", "1")
    assert runtime.taichi_defaults() == {"TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES": str(1 << 30)}
    monkeypatch.setenv("TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES", "5000000")
    assert runtime.taichi_defaults() == {}
    monkeypatch.setenv("TI_CFG_OPTIMIZATION", "")  # set but empty: Taichi ignores it, so do we
    assert runtime.taichi_defaults() == {"TI_CFG_OPTIMIZATION": "0"}


def test_init_hands_taichi_our_defaults():
    runtime.init("cpu")
    cfg = ti.lang.impl.current_cfg()
    if not os.environ.get("TI_CFG_OPTIMIZATION"):
        assert cfg.cfg_optimization is False
    if not os.environ.get("TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES"):
        assert cfg.offline_cache_max_size_of_files == runtime.OFFLINE_CACHE_BYTES
