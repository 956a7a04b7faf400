"""PyBullet kitchen simulator: world, robot, camera, executor, tasks."""
