function simrobot_world_memory(j, data)
% SIMROBOT_WORLD_MEMORY  (system) Robot j's memory (userdata) as the world starts: the world
%   file's memory for that robot, what its algorithm's first readmem returns.
  global SIMROBOT_WORLD_
  SIMROBOT_WORLD_.robots{j} = writemem(SIMROBOT_WORLD_.robots{j}, data);
end
