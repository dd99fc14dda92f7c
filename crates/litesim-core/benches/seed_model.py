"""The seed's Model SSP vehicle model, transcribed plainly into Python
(seed 000 §489.2.3), timed per actor-step. Prints the median ns per step.

Run by litesim-core's `vehicle` benchmark so both figures come from one run.
"""
import math
import statistics
import time

MAX_STEERING_WHEEL_ANGLE = 7.853981633974483
MAX_LINEAR_VELOCITY = 40.0


class Vector3:
    def __init__(self, x=0.0, y=0.0, z=0.0):
        self.x, self.y, self.z = x, y, z


class Vehicle:
    def __init__(self, length):
        self.wheelbase = 0.6 * length
        self.max_acceleration = 4.0
        self.max_wheels_angle = 35.0
        self.brake_deceleration = 30.0
        self.free_deceleration = 2.0
        self.position = Vector3()
        self.velocity = Vector3(10.0)
        self.rad_angle = 0.0
        self.angular_velocity = 0.0
        self.acceleration = 0.0
        self.dt = 0.02

    def set_acc_from_throttle_brake(self, throttle, brake):
        if brake > 0:
            self.acceleration = -brake * self.brake_deceleration
        elif throttle > 0:
            self.acceleration = throttle * self.max_acceleration
        else:
            self.acceleration = -math.copysign(self.free_deceleration, self.velocity.x)

    def set_angular_velocity_from_steer(self, steering_wheel_position):
        wheels_angle = (steering_wheel_position / MAX_STEERING_WHEEL_ANGLE) * self.max_wheels_angle
        if wheels_angle == 0:
            self.angular_velocity = 0.0
            return
        turning_radius = self.wheelbase / math.sin(math.radians(wheels_angle))
        self.angular_velocity = self.velocity.x / turning_radius

    def calc_new_pos(self):
        self.velocity.x += self.acceleration * self.dt
        self.velocity.x = min(self.velocity.x, MAX_LINEAR_VELOCITY)
        self.velocity.x = max(0, self.velocity.x)
        self.rad_angle += self.angular_velocity * self.dt
        self.position.x += self.velocity.x * math.cos(self.rad_angle) * self.dt
        self.position.y += self.velocity.x * math.sin(self.rad_angle) * self.dt

    def step(self, throttle, brake, steer):
        self.set_acc_from_throttle_brake(throttle, brake)
        self.set_angular_velocity_from_steer(steer)
        self.calc_new_pos()


def main():
    n = 20000
    samples = []
    for _ in range(15):
        v = Vehicle(4.5)
        t0 = time.perf_counter_ns()
        for _ in range(n):
            v.step(0.3, 0.0, 0.2 * MAX_STEERING_WHEEL_ANGLE)
        samples.append((time.perf_counter_ns() - t0) / n)
    print(f"{statistics.median(samples):.1f}")


if __name__ == "__main__":
    main()
