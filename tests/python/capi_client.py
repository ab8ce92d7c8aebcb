"""A ctypes client of the C API (capi/include/skinspheres/skinspheres.h): the C++ API's answers
for the same inputs, to compare the Python module with."""

import ctypes as C

import numpy as np

SPHERE_PAIR = np.dtype([("sphere_i", "<u4"), ("sphere_j", "<u4"), ("depth", "<f4"), ("part_i", "<u2"), ("part_j", "<u2")])
PART_CONTACT = np.dtype(
    [
        ("part_a", "<u2"),
        ("part_b", "<u2"),
        ("first_triangle_pair", "<u4"),
        ("triangle_pair_count", "<u4"),
        ("intersecting_count", "<u4"),
        ("sphere_pair_count", "<u4"),
        ("depth", "<f4"),
        ("min_distance", "<f4"),
        ("normal", "<f4", (3,)),
        ("center", "<f4", (3,)),
        ("kind", "<u4"),
    ]
)
TRIANGLE_CONTACT = np.dtype(
    [
        ("triangle_a", "<u4"),
        ("triangle_b", "<u4"),
        ("kind", "<u4"),
        ("distance", "<f4"),
        ("point", "<f4", (3,)),
        ("on_a", "<f4", (3,)),
        ("on_b", "<f4", (3,)),
    ]
)
ALL_PART_PAIRS = C.c_size_t(-1).value


class _Options(C.Structure):
    _fields_ = [("struct_size", C.c_size_t), ("narrow_margin", C.c_float), ("touch_tolerance_share", C.c_float)]


class CApi:
    def __init__(self, path):
        self.lib = C.CDLL(path)
        L = self.lib
        p, sz = C.c_void_p, C.c_size_t
        L.skinspheres_last_error.restype = C.c_char_p
        L.skinspheres_asset_load_file_with.argtypes = [C.c_char_p, C.POINTER(_Options), C.POINTER(p)]
        L.skinspheres_asset_release.argtypes = [p]
        L.skinspheres_instance_create.argtypes = [p, C.POINTER(C.c_char_p), sz, C.POINTER(p)]
        L.skinspheres_instance_destroy.argtypes = [p]
        L.skinspheres_instance_update_fast.argtypes = [p, p, sz]
        L.skinspheres_instance_update_exact.argtypes = [p, p, sz, p, sz]
        L.skinspheres_instance_find_sphere_pairs.argtypes = [p, C.POINTER(sz)]
        L.skinspheres_instance_get_sphere_pairs.argtypes = [p, p, sz, C.POINTER(sz)]
        L.skinspheres_instance_find_contacts.argtypes = [p, p, sz, C.POINTER(sz), C.POINTER(sz)]
        L.skinspheres_instance_get_part_contacts.argtypes = [p, p, sz, C.POINTER(sz)]
        L.skinspheres_instance_get_triangle_contacts.argtypes = [p, sz, p, sz, C.POINTER(sz)]

    def check(self, status):
        if status != 0:
            raise RuntimeError(f"C API status {status}: {self.lib.skinspheres_last_error().decode()}")


class CInstance:
    """One asset and one instance, created from a sphere-set file and an engine joint list."""

    def __init__(self, api, set_path, joint_names, margin=0.0, touch_tolerance=0.0):
        self.api, L = api, api.lib
        options = _Options(C.sizeof(_Options), margin, touch_tolerance)
        self.asset, self.inst = C.c_void_p(), C.c_void_p()
        api.check(L.skinspheres_asset_load_file_with(set_path.encode(), C.byref(options), C.byref(self.asset)))
        if joint_names is None:  # the set's own order
            api.check(L.skinspheres_instance_create(self.asset, None, 0, C.byref(self.inst)))
        else:
            names = (C.c_char_p * len(joint_names))(*[n.encode() for n in joint_names])
            api.check(L.skinspheres_instance_create(self.asset, names, len(joint_names), C.byref(self.inst)))

    def close(self):
        self.api.lib.skinspheres_instance_destroy(self.inst)
        self.api.lib.skinspheres_asset_release(self.asset)

    def frame(self, world, positions=None):
        """(sphere pairs, part contacts, triangle contacts) for math-layout matrices world (J, 4, 4)
        and, in exact mode, skinned positions (V, 3); as float32, packed the C API's way."""
        L, api, sz = self.api.lib, self.api, C.c_size_t
        columns = np.ascontiguousarray(np.swapaxes(world, 1, 2), np.float32)  # column-major per joint
        if positions is None:
            api.check(L.skinspheres_instance_update_fast(self.inst, columns.ctypes.data, len(world)))
        else:
            packed = np.ascontiguousarray(positions, np.float32)
            api.check(
                L.skinspheres_instance_update_exact(
                    self.inst, packed.ctypes.data, len(packed), columns.ctypes.data, len(world)
                )
            )
        n = sz()
        api.check(L.skinspheres_instance_find_sphere_pairs(self.inst, C.byref(n)))
        pairs = np.zeros(n.value, SPHERE_PAIR)
        api.check(L.skinspheres_instance_get_sphere_pairs(self.inst, pairs.ctypes.data, n.value, C.byref(n)))
        parts_n, tris_n = sz(), sz()
        pos = None if positions is None else packed.ctypes.data
        count = 0 if positions is None else len(packed)
        api.check(L.skinspheres_instance_find_contacts(self.inst, pos, count, C.byref(parts_n), C.byref(tris_n)))
        parts = np.zeros(parts_n.value, PART_CONTACT)
        tris = np.zeros(tris_n.value, TRIANGLE_CONTACT)
        api.check(L.skinspheres_instance_get_part_contacts(self.inst, parts.ctypes.data, parts_n.value, C.byref(n)))
        api.check(
            L.skinspheres_instance_get_triangle_contacts(
                self.inst, ALL_PART_PAIRS, tris.ctypes.data, tris_n.value, C.byref(n)
            )
        )
        return pairs, parts, tris
