"""Penalty contact: contact surfaces and gap projection
(:mod:`~fe_impact.contact.surfaces`), the contact zone
(:mod:`~fe_impact.contact.zone`), the penalty complementarity problem
(:mod:`~fe_impact.contact.lcp`), gaps linearised for time integration
(:mod:`~fe_impact.contact.linearised`) and an implicit step's contact
condensed onto the zone (:mod:`~fe_impact.contact.condensed`)."""
