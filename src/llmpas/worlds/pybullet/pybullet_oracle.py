"""The PyBullet world's labelled oracle (an upper bound, never a default): goals from the
simulator's TRUE state."""

from __future__ import annotations

from llmpas.language.logic import Atom, Not
from llmpas.reasoning.truth_oracle import TruthOracle
from llmpas.worlds.pybullet.pybullet_plugin import PyBulletSession
from llmpas.worlds.pybullet.pybullet_scenarios import bottom, over
from llmpas.worlds.pybullet.scene import RIM_MARGIN, Scene


class Oracle(TruthOracle):
    """Goals from the true scene for the anomaly in each request."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene

    def goals_for(self, atom: Atom, negated: bool) -> list[Atom | Not]:
        scene = self.scene
        if atom.predicate == "on" and not negated:
            at, _ = scene.pose(atom.args[0])
            table = next(
                (t for t, rect in scene.tables.items() if rect.contains(at[0], at[1])), None
            )
            return [Atom("scanned", (table,))] if table else []
        if atom.predicate == "full":
            return self._clear(self._inside(atom.args[0]))
        if atom.predicate == "accessible" and not negated:
            return self._clear(self._covering(atom.args[0]))
        return []

    def _inside(self, bowl: str) -> list[str]:
        """The cubes in the bowl (not the one held)."""
        scene = self.scene
        return [
            o.name
            for o in scene.config.objects
            if o.kind == "cube" and o.name != scene.held and self._in(o.name, bowl)
        ]

    def _covering(self, region: str) -> list[str]:
        """What lies over a bowl, above its rim (a lid): in the truth, not in any belief."""
        scene = self.scene
        if region not in {o.name for o in scene.config.objects}:
            return []
        rim = float(scene.pose(region)[0][2]) + scene.config.obj(region).height
        return [
            o.name
            for o in scene.config.objects
            if o.name not in (region, scene.held)
            and over(scene, o.name, region)
            and bottom(scene, o.name) > rim - RIM_MARGIN
        ]

    def _clear(self, blockers: list[str]) -> list[Atom | Not]:
        """Put the first of ``blockers`` on a table nothing is on (else the first table)."""
        scene = self.scene
        occupied = {
            t
            for o in scene.config.objects
            for t, rect in scene.tables.items()
            if rect.contains(*scene.pose(o.name)[0][:2]) and o.name != scene.held
        }
        free = [t for t in sorted(scene.tables) if t not in occupied] or sorted(scene.tables)
        return [Atom("on", (blockers[0], free[0]))] if blockers else []

    def _in(self, obj: str, bowl: str) -> bool:
        a, _ = self.scene.pose(obj)
        b, _ = self.scene.pose(bowl)
        half = self.scene.config.obj(bowl).size / 2
        return abs(a[0] - b[0]) < half and abs(a[1] - b[1]) < half


def oracle(session: PyBulletSession) -> Oracle:
    return Oracle(session.scene)


__all__ = ["Oracle", "oracle"]
