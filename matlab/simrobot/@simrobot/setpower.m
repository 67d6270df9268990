function new = setpower(simrobot, power)
% SETPOWER  Switch the robot on or off.
%   new = setpower(simrobot, power), power 1/0 or 'on'/'off'. A robot switched off keeps its
%   place (its wheel speeds are kept for when it is switched on again).
  if ischar(power)
    switch lower(power)
      case 'on'
        power = 1;
      case 'off'
        power = 0;
      otherwise
        error('setpower: expected 0/1 or ''on''/''off'', got ''%s''', power);
    end
  elseif ~(isscalar(power) && (isnumeric(power) || islogical(power)))
    error('setpower: expected 0/1 or ''on''/''off''');
  end
  simrobot.power = double(power ~= 0);
  new = simrobot;
end
