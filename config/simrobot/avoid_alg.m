function new = avoid_alg(simrobot, matrix, step)
% AVOID_ALG  An algorithm in the original's alg2 style: steer left when the front ultrasonic
% sensor 'sens1' sees something nearer than 20 cells (20 cm), else go straight on.
% Its Python twin is simrobot_avoid (0.20 m; [0 0.5] and [0.5 0.5] rad/s): the same tracks.
% Run it on the demo world: robot_sims simrobot_world --ros-args -p world_file:=simrobot/demo_matlab.yaml

% sensor reading; num, the nearest obstacle's number, is not used
[dist, num] = readusonic(simrobot, 'sens1', matrix);

if dist < 20
  simrobot = setvel(simrobot, [0 0.5]);    % turn left
else
  simrobot = setvel(simrobot, [0.5 0.5]);  % straight on
end
new = simrobot;
