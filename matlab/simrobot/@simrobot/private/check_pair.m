function check_pair(value, caller)
% CHECK_PAIR  (system) An error unless value is two finite real numbers [left right].
  if ~isnumeric(value) || numel(value) ~= 2 || ~isreal(value) || ~all(isfinite(double(value(:))))
    error('%s: expected [left right], two finite numbers, got %s', caller, mat2str(value));
  end
end
