"""OpenBLAS kernels for this CPU, chosen before the extension loads OpenBLAS (the Python side of
core/blas_select.h; the same decision table, tested on the same cases: tests/data/blas/coretype_cases.json).

Debian's OpenBLAS 0.3.21 does not know recent CPUs and then runs generic SSE kernels. OpenBLAS reads
OPENBLAS_CORETYPE once, when it is loaded; so before `freeloc._freeloc` (which loads it) is imported, a short-lived
child process asks OpenBLAS which core it detects, and OPENBLAS_CORETYPE is set when that core is generic and the CPU
runs better kernels. A user-set OPENBLAS_CORETYPE, or FREELOC_BLAS_SELECT=0, is left alone.
"""

import os
import subprocess
import sys

_GENERIC = {"prescott", "core2", "penryn", "dunnington", "nehalem", "atom", "katmai", "coppermine", "northwood",
            "banias", "opteron", "opteron_sse3", "barcelona", "bobcat", "nano", "unknown", "generic"}


def choose_coretype(vendor, flags, reported):
    """The OPENBLAS_CORETYPE to set for a CPU (vendor, set of /proc/cpuinfo flags) on which OpenBLAS reported
    `reported` ('' when the BLAS is not OpenBLAS); '' to leave OpenBLAS's choice."""
    if not reported or reported.strip().lower() not in _GENERIC:
        return ""
    if {"avx512f", "avx512bw", "avx512vl", "avx512dq"} <= flags:
        return "Cooperlake" if "avx512_bf16" in flags else "SkylakeX"
    if {"avx2", "fma"} <= flags:
        return "Zen" if vendor == "AuthenticAMD" else "Haswell"
    if "avx" in flags:
        return "Sandybridge"
    return ""


def this_cpu():
    """(vendor, flags) of the first processor in /proc/cpuinfo; ('', set()) when unreadable."""
    vendor, flags = "", set()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, value = line.partition(":")
                key = key.strip()
                if key == "processor" and (vendor or flags):
                    break
                if key == "vendor_id":
                    vendor = value.strip()
                elif key == "flags":
                    flags = set(value.split())
    except OSError:
        pass
    return vendor, flags


_PROBE = ("import ctypes, ctypes.util\n"
          "for n in ('libopenblas.so.0', 'libblas.so.3', ctypes.util.find_library('openblas')):\n"
          "    try:\n"
          "        f = ctypes.CDLL(n).openblas_get_corename\n"
          "    except (OSError, AttributeError, TypeError):\n"
          "        continue\n"
          "    f.restype = ctypes.c_char_p\n"
          "    print(f().decode()); break\n")


def select():
    """Sets OPENBLAS_CORETYPE for this process when OpenBLAS would run generic kernels; returns what was set."""
    if os.environ.get("OPENBLAS_CORETYPE") or os.environ.get("FREELOC_BLAS_SELECT") == "0":
        return ""
    try:
        out = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, timeout=10,
                             env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
        reported = out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""
    vendor, flags = this_cpu()
    pick = choose_coretype(vendor, flags, reported)
    if pick:
        os.environ["OPENBLAS_CORETYPE"] = pick
        os.environ["FREELOC_BLAS_SELECTED"] = reported + " -> " + pick
    return pick
