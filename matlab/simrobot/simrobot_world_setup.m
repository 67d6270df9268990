function simrobot_world_setup(names, afs, sensor_robot, sensor_names, sensor_types, first, last, matrix)
% SIMROBOT_WORLD_SETUP  (system) The world's robots for simrobot_world_step, built once.
%   names, afs: cell arrays (robot names, algorithm function names, '' for none);
%   sensor_robot, first, last: per sensor, its robot (1-based) and its readings' index range;
%   sensor_names, sensor_types: per sensor, cell arrays of strings; matrix: the world's matrix.
  global SIMROBOT_WORLD_
  n = numel(names);
  robots = cell(1, n);
  for j = 1:n
    mine = find(sensor_robot == j);
    sensors = struct('name', {}, 'type', {}, 'first', {}, 'last', {}, 'distance', {}, 'num', {});
    for m = 1:numel(mine)
      k = mine(m);
      sensors(m) = struct('name', sensor_names{k}, 'type', sensor_types{k}, 'first', first(k), ...
                          'last', last(k), 'distance', [], 'num', []);
    end
    s = struct('name', names{j}, 'number', j + 1, 'af', afs{j}, 'position', [0 0], 'heading', 0, ...
               'velocity', [0 0], 'accel', [0 0], 'power', 1, 'crashed', 0, 'userdata', [], ...
               'sensors', sensors);
    robots{j} = simrobot(s);
  end
  SIMROBOT_WORLD_ = struct('robots', {robots}, 'afs', {afs}, 'running', 0, 'matrix', matrix);
end
