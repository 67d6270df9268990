function data = readmem(simrobot)
% READMEM  The robot's memory (userdata): whatever writemem stored, [] at the start.
%   data = readmem(simrobot). The memory lasts from step to step while the world runs.
  data = simrobot.userdata;
end
