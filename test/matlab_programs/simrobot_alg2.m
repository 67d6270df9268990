function new = simrobot_alg2(simrobot, matrix, step)
% SIMROBOT_ALG2  An alg2-style algorithm (our own, in the original's style): steer left when the
% front ultrasonic sensor sees something nearer than 20 cells, else go straight on.
% Its Python twin is simrobot_sim/avoid.py (20 cm = 0.20 m; [0 0.5] and [0.5 0.5] rad/s).

% sensor reading; num, the nearest obstacle's number, is not used
[dist, num] = readusonic(simrobot, 'sens1', matrix);

if dist < 20
  simrobot = setvel(simrobot, [0 0.5]);    % turn left
else
  simrobot = setvel(simrobot, [0.5 0.5]);  % straight on
end
new = simrobot;
