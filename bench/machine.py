"""What the benchmark tables name: the CPU model the figures were measured on."""

import platform


def cpu_model():
    """The CPU's model name, with its family and model numbers (a virtual machine may report
    only "AMD EPYC", which names no generation)."""
    name, family, model = None, None, None
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, value = line.partition(":")
                key, value = key.strip(), value.strip()
                if key == "model name" and name is None:
                    name = value
                elif key == "cpu family" and family is None:
                    family = value
                elif key == "model" and model is None:
                    model = value
    except OSError:
        pass
    if name is None:
        return platform.processor() or platform.machine() or "unknown CPU"
    return f"{name} (family {family}, model {model})" if family and model else name
