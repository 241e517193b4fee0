"""sim.results: What an episode counts and writes: metrics, CSVs, manifests."""
