"""The firmware's wall-stiffness limit: HG_SCENE_K_MAX (3500 N/m, the safety limit) in every
build; the separately named HG_SCENE_K_MAX_TEST only where a simulation build defines it (the
Z-width sweep, scenes/sweeps/README.md). hg_scene_check() compiled both ways with the
firmware's own flags and called on the limits' edges."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from hapgate.runners.cosim import FW_WARN

FW = Path(__file__).resolve().parents[2] / "dsp-fw"
MAIN = r"""
#include <stdio.h>
#include "hg_scene.h"
int main(void) {
    const float ks[] = { 3500.0f, 3500.5f, 50000.0f, 50001.0f };
    for (int i = 0; i < 4; i++) {
        hg_scene_t sc = { HG_SCENE_WALL, { 0, 0.07f, 0 }, { 0, -1, 0 }, ks[i], 0, 0 };
        printf("%d", hg_scene_check(&sc) == 0);
    }
    return 0;
}
"""


@pytest.mark.parametrize("defines, want", [((), "1000"),
                                           (("-DHG_SCENE_K_MAX_TEST=50000.0",), "1110")])
def test_k_limit_default_and_test_build(tmp_path: Path, defines: tuple[str, ...],
                                        want: str) -> None:
    (tmp_path / "main.c").write_text(MAIN)
    exe = tmp_path / "k_limit"
    subprocess.run(["gcc", "-std=c99", *FW_WARN, *defines, "-I", str(FW / "include"),
                    str(tmp_path / "main.c"), str(FW / "src" / "hg_scene.c"), "-lm",
                    "-o", str(exe)], check=True, capture_output=True, text=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    assert out == want
