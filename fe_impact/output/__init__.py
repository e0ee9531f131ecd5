"""Result files: atomic JSON/CSV writers, VTU/PVD series and the solver
summaries. A leaf: no numerical module imports it."""
