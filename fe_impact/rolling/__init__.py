"""The rolling mesh: tooth sectors turning through mesh at speed (transient FE).

- :mod:`~fe_impact.rolling.sectors`: the sector mesh (several teeth, both flanks);
- :mod:`~fe_impact.rolling.model`: floating-frame bodies, contact geometry, Newmark;
- :mod:`~fe_impact.rolling.bodies`: the bodies' matrices from the mesh;
- :mod:`~fe_impact.rolling.run`: the time loop and its record (:class:`RollResult`).
"""
