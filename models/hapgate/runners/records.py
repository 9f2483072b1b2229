"""The native harnesses' record files as numpy reads them: the layouts of
tb/native/device/harness_common.h's FrameRec, TickRec and LoadRec (tb/device/test_record_layout.py
compares them field by field). Here, below both readers: the device harnesses
(hapgate.device.harness re-exports them) and the co-simulation (hapgate.runners.cosim)."""

from __future__ import annotations

import numpy as np

FRAME_DT = np.dtype([("t", "<f8"), ("q", "<f8", 3), ("p", "<f8", 3), ("f_hand", "<f8", 3),
                     ("tau", "<f8", 3), ("i_ab", "<f8", 6), ("energy", "<f8"),
                     ("dac", "<i2", 6), ("pad", "<i2"),
                     ("pad2", "<u4")], align=True)
TICK_DT = np.dtype([("t", "<f8"), ("q_fw", "<f8", 3), ("q_true", "<f8", 3), ("p_fw", "<f8", 3),
                    ("f_fw", "<f8", 3), ("tau_fw", "<f8", 3), ("pos_err", "<i4", 3),
                    ("pos", "<i4", 3), ("status", "<u4"), ("err", "u1"), ("err_axis", "u1"),
                    ("drive", "u1"),
                    ("pad", "u1")], align=True)
LOAD_DT = np.dtype([("edge", "<i8"), ("ch", "<i4"), ("code", "<i4")])
