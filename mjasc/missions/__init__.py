"""Missions: the thesis's mission primitives (go-to-formation, cooperative path following,
cooperative target tracking) chained per scenario (docs/missions.md)."""
