"""The characters the Python tests play: each fitted once per session, saved as .ssb, posed by the
independent sampler (gltf_sampler.py)."""

import numpy as np

import skinspheres as ss
from gltf_sampler import Gltf, playback_time, skin

FPS = 30.0


class Character:
    def __init__(self, glb, set_path):
        self.glb = glb
        self.set_path = set_path
        self.gltf = Gltf(glb)
        self.spheres = ss.fit(glb)
        self.spheres.save(set_path)
        self.mesh = self.spheres.mesh
        names = self.spheres.joint_names
        self.set_nodes = self._match_nodes()
        if len(set(names)) == len(names):
            # The engine's joint order: the set's reversed, and a joint the set does not know.
            self.engine_names = list(reversed(names)) + ["engine_helper_bone"]
            self.engine_nodes = list(reversed(self.set_nodes)) + [None]
        else:
            # Names that repeat (RobotExpressive: a joint and a mesh node share a name) cannot be
            # mapped by name: the engine passes the set's own order.
            self.engine_names = None
            self.engine_nodes = list(self.set_nodes)

    def _match_nodes(self):
        """The glTF node of each set joint: by name among the children of its parent's node (the set
        lists parents first), so that repeated names elsewhere in the file do not matter."""
        nodes = self.gltf.nodes
        roots = [i for i in range(len(nodes)) if self.gltf.parent[i] < 0]
        out = []
        for name, parent in zip(self.spheres.joint_names, self.spheres.joint_parents):
            candidates = roots if parent < 0 else nodes[out[parent]].get("children", [])
            match = [c for c in candidates if nodes[c].get("name") == name]
            assert len(match) == 1, f"{self.glb}: set joint {name!r} matches nodes {match}"
            out.append(match[0])
        return out

    def clips(self):
        return range(len(self.gltf.animations))

    def frame_times(self, clip):
        """The clip times of play()'s frames at FPS: 0, 1/FPS, ... through the clip's end."""
        duration = self.gltf.duration(clip)
        count = int(np.floor(duration * FPS + 1e-4)) + 1
        return [playback_time(k / FPS, duration) for k in range(count)]

    def poses(self, random_poses=12):
        """Every frame of every clip, then random poses (each joint turned by up to 0.6 rad from the
        first clip's start): (clip, time, turns) triples."""
        for clip in self.clips():
            for time in self.frame_times(clip):
                yield clip, time, None
        rng = np.random.default_rng(7)
        skin_nodes = sorted(set(self.set_nodes[j] for j in self.mesh["bind_joints"]))
        for _ in range(random_poses):
            yield (0 if self.gltf.animations else None), 0.0, self.gltf.random_turns(rng, skin_nodes, 0.6)

    def pose(self, clip, time, turns=None):
        """(engine-order world matrices (J + 1, 4, 4) float64, set-order matrices (J, 4, 4))."""
        world = self.gltf.world(clip, time, turns)
        set_world = np.stack([world[n] for n in self.set_nodes])
        engine = np.stack([np.eye(4) if n is None else world[n] for n in self.engine_nodes])
        return engine, set_world

    def skinned(self, set_world):
        return skin(self.mesh, set_world)


_cache = {}


def character(name, glb, tmp_path_factory):
    if name not in _cache:
        folder = tmp_path_factory.mktemp("set_" + name.replace(".", "_"))
        _cache[name] = Character(glb, str(folder / (name + ".ssb")))
    return _cache[name]
