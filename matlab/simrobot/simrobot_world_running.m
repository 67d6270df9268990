function j = simrobot_world_running()
% SIMROBOT_WORLD_RUNNING  (system) The robot (1-based) whose algorithm simrobot_world_step was
%   running when it was interrupted; 0 when it finished.
  global SIMROBOT_WORLD_
  j = SIMROBOT_WORLD_.running;
end
