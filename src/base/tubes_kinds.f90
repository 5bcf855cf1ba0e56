!> Working precision and counter kinds used by every tubes module.
module tubes_kinds
  use, intrinsic :: iso_fortran_env, only: real64, int64, real128
  implicit none
  private
  integer, parameter, public :: wp = real64   !! every real in tubes (== c_double on our targets)
  integer, parameter, public :: qp = real128  !! quad precision, reference solutions only
  integer, parameter, public :: i8 = int64    !! step and sample counters
  real(wp), parameter, public :: PI = acos(-1.0_wp)   !! pi, the double nearest it (the one definition)
end module tubes_kinds
