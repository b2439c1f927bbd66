"""A Ray cluster's head node for the cluster tests: started as a separate process (its workers see
its environment, not the test's), it prints its address and holds it until stdin closes.
It imports only Ray: the tests give it a PYTHONPATH on which hriplan cannot be imported.

Run: python ray_head.py CPUS
"""

import sys

import ray

ray.init(num_cpus=int(sys.argv[1]), include_dashboard=False, logging_level="ERROR", log_to_driver=False)
print(ray.get_runtime_context().gcs_address, flush=True)
sys.stdin.read()
ray.shutdown()
