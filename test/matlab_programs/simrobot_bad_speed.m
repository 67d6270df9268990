function new = simrobot_bad_speed(simrobot, matrix, step)
% SIMROBOT_BAD_SPEED  Sets a wheel speed that is not a number.
simrobot = setvel(simrobot, [NaN 0.5]);
new = simrobot;
