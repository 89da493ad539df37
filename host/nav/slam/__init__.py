"""The mapper's parts: the occupancy counts that keep thin walls (:mod:`.occupancy`), the pose
graph and its optimiser (:mod:`.graph`), loop closure (:mod:`.loops`) and the saved graph
(:mod:`.store`); :class:`.mapper.Mapper` puts them together and is what the survey runs."""
