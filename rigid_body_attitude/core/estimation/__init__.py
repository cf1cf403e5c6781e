"""The IMU: calibration, levelling (alignment), rest detection, gyro error model, covariance.

What a real gyro and accelerometer need before and while their samples drive the attitude:
:mod:`.calibration` (the calibration file), :mod:`.alignment` (roll and pitch from gravity),
:mod:`.rest` (when the sensor is still), :mod:`.gyro_error_model` (kalibr's noise names) and
:mod:`.attitude_covariance` (the attitude error covariance those errors give).
"""
