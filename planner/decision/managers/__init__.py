"""planner.decision.managers: the decision managers themselves (the thesis's Q-learning, our
rollout, look-ahead and learned policy, the proximity, FIFO and greedy rules,
the thesis's random picker, the best order over the items in view); the oracle bound
and what they share (interface, candidates, the thesis's grid, the registry) are one level up."""
