function new = simrobot_endless(simrobot, matrix, step)
% SIMROBOT_ENDLESS  Drives straight on, then never returns from step 3.
simrobot = setvel(simrobot, [0.5 0.5]);
while step == 3
end
new = simrobot;
