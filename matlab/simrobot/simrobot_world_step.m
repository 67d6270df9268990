function [velocity, accel, power, crashed, errors] = simrobot_world_step(active, pose, velocity, ...
    accel, power, crashed, values, nums, changed, now, step)
% SIMROBOT_WORLD_STEP  (system) Run every active robot's algorithm once on this step's state.
%   pose: n-by-3 [x y heading] (cells, degrees); velocity, accel: n-by-2; power, crashed: n;
%   values, nums: every sensor's readings; changed, now: the matrix's cells (linear indices) that
%   changed since the last step and their values (the matrix itself stays here); step: 1, 2, ...
%   Returns the commands each algorithm left and, per robot, '' or its error's message.
  global SIMROBOT_WORLD_
  n = numel(SIMROBOT_WORLD_.robots);
  SIMROBOT_WORLD_.matrix(changed) = now;
  matrix = SIMROBOT_WORLD_.matrix;
  errors = repmat({''}, 1, n);
  for j = find(active(:)')
    SIMROBOT_WORLD_.running = j;
    r = simrobot_refresh(SIMROBOT_WORLD_.robots{j}, pose(j, 1:2), pose(j, 3), velocity(j, :), ...
                         accel(j, :), power(j), crashed(j), values, nums);
    try
      new = feval(SIMROBOT_WORLD_.afs{j}, r, matrix, step);
      if ~isa(new, 'simrobot')
        error('%s must return the robot (end it with: new = simrobot;)', SIMROBOT_WORLD_.afs{j});
      end
    catch err
      errors{j} = describe(err, SIMROBOT_WORLD_.afs{j});
      continue
    end
    SIMROBOT_WORLD_.robots{j} = new;
    [velocity(j, :), accel(j, :), power(j), crashed(j)] = simrobot_commands(new);
  end
  SIMROBOT_WORLD_.running = 0;
end

function text = describe(err, af)
  % the message and the algorithm's line that led to it (its first frame on the stack, if any)
  text = err.message;
  for k = 1:numel(err.stack)
    name = err.stack(k).name;
    if strcmp(name, af) || strncmp(name, [af '>'], numel(af) + 1)
      text = sprintf('%s (%s line %d)', text, name, err.stack(k).line);
      return
    end
  end
end
