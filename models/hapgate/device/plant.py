"""The plant of the virtual device from Python: tb/native/device/plant.cpp (the same code the
closed-loop harness links) as a shared library through ctypes, for its own tests and for tools.

`Plant(config_text)` wraps one plant; `config_text` is the harness's plant configuration
(`hapgate.device.runner.plant_config` writes it from a scene; README.md lists the keys).
"""

from __future__ import annotations

import ctypes as C
from pathlib import Path

import numpy as np

from ..base import cache, cbuild
from ..base.paths import BUILD, TB

SRC = TB / "native" / "device" / "plant.cpp"
HDR = TB / "native" / "device" / "plant.h"
DAC_HDR = TB / "native" / "device" / "dac_word.h"
SO = "libhgplant.so"


class Out(C.Structure):
    _fields_ = [("t", C.c_double), ("q", C.c_double * 3), ("qd", C.c_double * 3),
                ("p", C.c_double * 3), ("v", C.c_double * 3), ("f_hand", C.c_double * 3),
                ("tau", C.c_double * 3), ("i_ab", C.c_double * 6), ("energy", C.c_double),
                ("theta_e", C.c_double * 3), ("qm", C.c_double * 3), ("qdm", C.c_double * 3)]


def library() -> C.CDLL:
    """Compile plant.cpp into a shared library (cached by source hash) and load it."""
    def build(bdir: Path) -> None:
        cbuild.run(["g++", "-std=c++17", "-O2", "-Wall", "-Wextra", "-Werror", "-shared",
                    "-fPIC", str(SRC), "-o", str(bdir / SO)], bdir / "build.log", "plant library")

    key = cache.digest(files=[SRC, HDR, DAC_HDR])
    so = cache.cached_dir(BUILD / "native", f"plant-{key}", build, done=SO) / SO
    lib = C.CDLL(str(so))
    d3 = C.POINTER(C.c_double)
    lib.hg_plant_new.restype = C.c_void_p
    lib.hg_plant_new.argtypes = [C.c_char_p, C.c_char_p, C.c_int]
    lib.hg_plant_free.argtypes = [C.c_void_p]
    lib.hg_plant_set_dac.argtypes = [C.c_void_p, C.c_int, C.c_int]
    lib.hg_plant_step.argtypes = [C.c_void_p, C.c_int]
    lib.hg_plant_hold.argtypes = [C.c_void_p, C.c_int]
    lib.hg_plant_set_q.argtypes = [C.c_void_p, d3, d3]
    lib.hg_plant_adc.argtypes = [C.c_void_p, C.POINTER(C.c_int8), C.POINTER(C.c_int8),
                                 C.POINTER(C.c_uint8)]
    lib.hg_plant_read.argtypes = [C.c_void_p, C.POINTER(Out)]
    lib.hg_plant_mech_read.argtypes = [C.c_void_p, C.c_int, C.POINTER(Out)]
    lib.hg_plant_encode.argtypes = [C.c_void_p, C.c_int, d3, C.c_int, C.POINTER(C.c_int8),
                                    C.POINTER(C.c_int8)]
    lib.hg_plant_jac.argtypes = [C.c_void_p, d3, d3]
    return lib


class PlantError(ValueError):
    pass


def _out(o: Out) -> dict[str, np.ndarray | float]:
    return {name: (np.array(getattr(o, name)) if name not in ("t", "energy")
                   else float(getattr(o, name))) for name, _ in Out._fields_}


class Plant:
    """One plant instance (SI units)."""

    def __init__(self, config_text: str = "") -> None:
        self.lib = library()
        err = C.create_string_buffer(256)
        self.h = self.lib.hg_plant_new(config_text.encode(), err, 256)
        if not self.h:
            raise PlantError(err.value.decode())

    def __del__(self) -> None:
        if getattr(self, "h", None):
            self.lib.hg_plant_free(self.h)
            self.h = None

    def set_dac(self, ch: int, code: int) -> None:
        self.lib.hg_plant_set_dac(self.h, int(ch), int(code))

    def step(self, n: int = 1) -> None:
        self.lib.hg_plant_step(self.h, int(n))

    def hold(self, on: bool) -> None:
        self.lib.hg_plant_hold(self.h, int(on))

    def set_q(self, q: np.ndarray, qd: np.ndarray | None = None) -> None:
        qa = (C.c_double * 3)(*np.asarray(q, float))
        qda = (C.c_double * 3)(*(np.zeros(3) if qd is None else np.asarray(qd, float)))
        self.lib.hg_plant_set_q(self.h, qa, qda)

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """The plant's own Jacobian dp/dq at q (3x3)."""
        qa = (C.c_double * 3)(*np.asarray(q, float))
        out = (C.c_double * 9)()
        self.lib.hg_plant_jac(self.h, qa, out)
        return np.array(out).reshape(3, 3)

    def read(self) -> dict[str, np.ndarray | float]:
        o = Out()
        self.lib.hg_plant_read(self.h, C.byref(o))
        return _out(o)

    def mech_read(self, n_us: int = 1) -> dict[str, np.ndarray | float]:
        """One mechanics step of n_us (the multirate plant's), and the read-out of the state
        before it as the step itself evaluated it (its own trigonometry)."""
        o = Out()
        self.lib.hg_plant_mech_read(self.h, int(n_us), C.byref(o))
        return _out(o)

    def adc(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        a, b, ix = (C.c_int8 * 3)(), (C.c_int8 * 3)(), (C.c_uint8 * 3)()
        self.lib.hg_plant_adc(self.h, a, b, ix)
        return np.array(a), np.array(b), np.array(ix)

    def encode(self, axis: int, lines: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.ascontiguousarray(lines, dtype=np.float64)
        a = np.zeros(x.size, np.int8)
        b = np.zeros(x.size, np.int8)
        self.lib.hg_plant_encode(self.h, int(axis), x.ctypes.data_as(C.POINTER(C.c_double)),
                                 x.size, a.ctypes.data_as(C.POINTER(C.c_int8)),
                                 b.ctypes.data_as(C.POINTER(C.c_int8)))
        return a, b


def config(**kw: object) -> str:
    """A plant configuration from keyword values (sequences become space-separated lists)."""
    lines = []
    for k, v in kw.items():
        vals = np.ravel(np.asarray(v, dtype=float))
        lines.append(f"{k} = {' '.join(repr(float(x)) for x in vals)}")
    return "\n".join(lines) + "\n"
