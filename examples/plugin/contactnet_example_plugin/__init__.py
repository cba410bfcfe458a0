"""A contactnet plugin (examples/plugin): installed with pip, its robot, planner and terrain reach every command.

    pip install ./examples/plugin
    contactnet robot check a1
    contactnet simulate --robot a1 --terrain flat --gait trot --planner heuristic --vx 0.1 --json
    contactnet simulate --terrain gap_course --gait walk --planner wide_margin
"""
