"""**Oracle** for the tabletop world (a labelled upper bound, never a default): goals computed
from PyBullet's TRUE scene for the anomaly the request carries (``request.situation.constraint``,
the failed literal as data)."""

from __future__ import annotations

from llmpas.language.logic import Atom, Not
from llmpas.reasoning.truth_oracle import TruthOracle
from llmpas.worlds.tabletop.tabletop_session import TabletopSession


class TabletopOracle(TruthOracle):
    def __init__(self, session: TabletopSession) -> None:
        self.session = session

    def goals_for(self, atom: Atom, negated: bool) -> list[Atom | Not]:
        """``(full B)`` (also negated): every cube truly in bowl B to a table; ``(on O R)`` (a
        failed detection): look at the table O truly is on."""
        scene = self.session.scene
        if atom.predicate == "full":
            table = next(iter(scene.tables))
            return [
                Atom("on", (o.name, table))
                for o in scene.config.objects
                if o.kind == "cube"
                and o.name != scene.held
                and self._region(o.name) == atom.args[0]
            ]
        if atom.predicate == "on":
            region = self._region(atom.args[0])
            return [Atom("scanned", (region,))] if region in scene.tables else []
        return []

    def _region(self, obj: str) -> str | None:
        at, _ = self.session.scene.pose(obj)
        return self.session.scene.region_of(*at)


def oracle(session: TabletopSession) -> TabletopOracle:
    return TabletopOracle(session)


__all__ = ["TabletopOracle", "oracle"]
