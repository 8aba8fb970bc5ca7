"""sim_client.py with rcl_interfaces/ParameterEvent among its message types (for /gait/parameters):
``python gait_client.py DOMAIN SECONDS SCRIPT_JSON``, as sim_client.py."""

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import sim_client  # noqa: E402

sim_client.M.ParameterEvent = sim_client.M.ros_type("rcl_interfaces/msg/ParameterEvent")

if __name__ == "__main__":
    sim_client.main(int(sys.argv[1]), float(sys.argv[2]), json.loads(sys.argv[3]))
