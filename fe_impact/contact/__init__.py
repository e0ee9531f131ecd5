"""Penalty contact: contact surfaces and gap projection
(:mod:`~fe_impact.contact.surfaces`) and the contact zone
(:mod:`~fe_impact.contact.zone`)."""
