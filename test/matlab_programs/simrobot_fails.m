function new = simrobot_fails(simrobot, matrix, step)
% SIMROBOT_FAILS  Drives straight on, then calls a function that does not exist at step 5.
simrobot = setvel(simrobot, [0.5 0.5]);
if step == 5
  no_such_function_here(simrobot);
end
new = simrobot;
