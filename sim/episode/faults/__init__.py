"""The faults of a shift acting on an episode (`sim.config.faults` schedules them): one owner of
their state, `sim.episode.faults.cell_faults.CellFaults`."""
