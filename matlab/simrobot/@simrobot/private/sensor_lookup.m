function k = sensor_lookup(simrobot, sensor_name, caller)
% SENSOR_LOOKUP  (system) Index of the first sensor called sensor_name; an error naming the
%   robot's sensors when there is none.
  names = {simrobot.sensors.name};
  k = find(strcmp(names, sensor_name), 1);
  if isempty(k)
    if isempty(names)
      have = 'it has no sensors';
    else
      have = ['its sensors: ' strjoin(names, ', ')];
    end
    error('%s: robot ''%s'' has no sensor ''%s'' (%s)', caller, simrobot.name, ...
          num2str(sensor_name), have);
  end
end
