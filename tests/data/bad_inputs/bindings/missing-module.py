# expect: 3 :2: running it raised ModuleNotFoundError
import no_such_robot_driver_xyz
