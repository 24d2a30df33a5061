"""What this machine allows: memory a command plans to use is checked against what is available
before it starts, so that a request too large for it is a one-line error, not a MemoryError (or the
kernel's OOM killer) minutes in."""

import os


def available_memory():
    """Bytes of memory available to new allocations now: MemAvailable of /proc/meminfo on Linux,
    else the free physical pages (os.sysconf); None when neither can be read."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


def gigabytes(nbytes):
    """`nbytes` as text in GB (or MB below 1 GB), for messages."""
    return f"{nbytes / 1e9:.3g} GB" if nbytes >= 1e9 else f"{nbytes / 1e6:.3g} MB"


def check_fits(nbytes, what):
    """ValueError "`what` needs X GB, more than the Y GB available" when nbytes exceeds the memory
    available now (no check when that is unknown)."""
    available = available_memory()
    if available is not None and nbytes > available:
        raise ValueError(f"{what} needs {gigabytes(nbytes)}, more than the {gigabytes(available)} of memory available")
