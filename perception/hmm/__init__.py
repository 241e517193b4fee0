"""perception.hmm."""
