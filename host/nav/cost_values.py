"""The cost values of every costmap and of the planner that reads them, as Nav2's
``nav2_costmap_2d/cost_values.hpp`` defines them: 0 free, 1-252 inflated (the closer to an
obstacle the higher), 253 inscribed (the robot's centre here puts its body on an obstacle),
254 lethal (an obstacle cell), 255 no information."""

FREE_SPACE = 0
INSCRIBED_INFLATED_OBSTACLE = 253
LETHAL_OBSTACLE = 254
NO_INFORMATION = 255
MAX_NON_OBSTACLE = INSCRIBED_INFLATED_OBSTACLE - 1  # 252, the top of the inflated band
