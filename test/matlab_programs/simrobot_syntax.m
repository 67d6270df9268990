function new = simrobot_syntax(simrobot, matrix, step)
% SIMROBOT_SYNTAX  Does not parse (a bracket is never closed).
if step == (2
  simrobot = setvel(simrobot, [0.5 0.5]);
end
new = simrobot;
