"""``python -m melange_ti.probe ARCH PRECISION``: start Taichi on ``ARCH`` and run one small
kernel in ``PRECISION``, printing ``BACKEND name``, for Vulkan ``DEVICE type name`` (the
device Taichi takes, see :func:`vulkan_device`) and ``KERNEL ok``.

Run in a child process by :func:`melange_ti.runtime.probe`: Taichi's start-up on a device
can kill the process that tries it (a missing ``libcuda.so``, or a Vulkan loader pointed at
a missing driver, segfaults), and a device without f64 fails only when a kernel compiles.
"""

import ctypes
import ctypes.util
import os
import sys

import taichi as ti

# VkPhysicalDeviceType, by value
DEVICE_TYPES = ("other", "integrated", "discrete", "virtual", "cpu")


def vulkan_devices() -> list[tuple[str, str, int]]:
    """Every Vulkan device the system's loader (``libvulkan.so.1``, the one Taichi loads)
    lists: ``(type, name, score)``, ``type`` one of :data:`DEVICE_TYPES` (``"cpu"``: a CPU
    pretending to be a GPU, such as Mesa's lavapipe) and ``score`` Taichi 1.7's ranking
    (``get_device_score`` in its ``vulkan_device_creator.cpp``). Read with ctypes, five
    Vulkan calls: no Vulkan SDK, no ``vulkaninfo``, no Python package. Empty where the
    loader cannot be found or lists nothing."""
    name = ctypes.util.find_library("vulkan") or "libvulkan.so.1"
    try:
        vk = ctypes.CDLL(name)
    except OSError:
        return []

    class AppInfo(ctypes.Structure):
        _fields_ = [("sType", ctypes.c_int), ("pNext", ctypes.c_void_p), ("pApplicationName", ctypes.c_char_p),
                    ("applicationVersion", ctypes.c_uint32), ("pEngineName", ctypes.c_char_p),
                    ("engineVersion", ctypes.c_uint32), ("apiVersion", ctypes.c_uint32)]  # fmt: skip

    class InstanceInfo(ctypes.Structure):
        _fields_ = [("sType", ctypes.c_int), ("pNext", ctypes.c_void_p), ("flags", ctypes.c_uint32),
                    ("pApplicationInfo", ctypes.POINTER(AppInfo)), ("enabledLayerCount", ctypes.c_uint32),
                    ("ppEnabledLayerNames", ctypes.c_void_p), ("enabledExtensionCount", ctypes.c_uint32),
                    ("ppEnabledExtensionNames", ctypes.c_void_p)]  # fmt: skip

    app = AppInfo(0, None, b"melange_ti probe", 1, None, 0, (1 << 22))  # Vulkan 1.0: any loader takes it
    info = InstanceInfo(1, None, 0, ctypes.pointer(app), 0, None, 0, None)
    instance = ctypes.c_void_p()
    if vk.vkCreateInstance(ctypes.byref(info), None, ctypes.byref(instance)) != 0:
        return []
    try:
        count = ctypes.c_uint32(0)
        vk.vkEnumeratePhysicalDevices(instance, ctypes.byref(count), None)
        handles = (ctypes.c_void_p * count.value)()
        vk.vkEnumeratePhysicalDevices(instance, ctypes.byref(count), handles)
        out = []
        for handle in handles[: count.value]:
            # VkPhysicalDeviceProperties: apiVersion, driverVersion, vendorID, deviceID,
            # deviceType (4-byte fields), then deviceName[256]; the limits after it are not read
            props = ctypes.create_string_buffer(4096)
            vk.vkGetPhysicalDeviceProperties(ctypes.c_void_p(handle), props)
            api, kind = int.from_bytes(props.raw[0:4], "little"), int.from_bytes(props.raw[16:20], "little")
            label = props.raw[20:276].split(b"\0", 1)[0].decode(errors="replace")
            features = (ctypes.c_uint32 * 64)()  # VkPhysicalDeviceFeatures: 55 VkBool32, wideLines the 16th
            vk.vkGetPhysicalDeviceFeatures(ctypes.c_void_p(handle), features)
            families = ctypes.c_uint32(0)
            vk.vkGetPhysicalDeviceQueueFamilyProperties(ctypes.c_void_p(handle), ctypes.byref(families), None)
            queues = (ctypes.c_uint32 * (6 * families.value))()  # VkQueueFamilyProperties: queueFlags first, 24 bytes
            vk.vkGetPhysicalDeviceQueueFamilyProperties(ctypes.c_void_p(handle), ctypes.byref(families), queues)
            compute = any(queues[6 * f] & 0x2 for f in range(families.value))
            minor = (api >> 12) & 0x3FF
            score = 1000 * compute + 100 * bool(features[15]) + 500 * (kind == 1) + 1000 * (kind == 2) + 100 * minor
            out.append((DEVICE_TYPES[kind] if 0 <= kind < len(DEVICE_TYPES) else "other", label, score))
        return out
    finally:
        vk.vkDestroyInstance(instance, None)


def vulkan_device() -> tuple[str, str] | None:
    """``(type, name)`` of the device Taichi 1.7's Vulkan backend takes: the one
    ``TI_VISIBLE_DEVICE`` names if valid and able to compute, else the first of the highest
    score (its ``pick_physical_device``). None if unknown."""
    devices = vulkan_devices()
    chosen = os.environ.get("TI_VISIBLE_DEVICE", "")
    if chosen.strip().lstrip("-").isdigit() and 0 <= int(chosen) < len(devices) and devices[int(chosen)][2] > 0:
        return devices[int(chosen)][:2]
    best = max(devices, key=lambda d: d[2], default=None)  # max() keeps the first of equal scores, as Taichi
    return None if best is None or best[2] == 0 else best[:2]


@ti.kernel
def _fill(x: ti.types.ndarray()):
    for i in range(x.shape[0]):
        x[i] = ti.sqrt(1.0 + i) * 3.0


def main(arch: str, precision: str) -> int:
    fp = ti.f32 if precision == "f32" else ti.f64
    ti.init(arch=getattr(ti, arch), default_fp=fp, log_level=ti.ERROR)
    name = str(ti.lang.impl.current_cfg().arch).split(".")[-1]
    print("BACKEND", name, flush=True)
    if name in ("x64", "arm64"):
        return 0
    if name == "vulkan":
        device = vulkan_device()
        if device is not None:
            print("DEVICE", *device, flush=True)
    x = ti.ndarray(fp, shape=(4,))
    _fill(x)
    ok = abs(float(x.to_numpy()[1]) - 3.0 * 2.0**0.5) < 1e-5
    print("KERNEL", "ok" if ok else "wrong", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
