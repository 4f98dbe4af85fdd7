// The metric table (metric_table.hpp): one row per metric.
#include "demfem/compare/metric_table.hpp"

#include <algorithm>
#include <array>

namespace demfem::compare {
namespace {

namespace col = output::col;
namespace file = output::file;

constexpr Metric kTable[] = {
    // ---- walls (walls.csv) ----
    {.key = "thrust",
     .quantity = "thrust",
     .owners = Owners::Walls,
     .source = {Read::Column, file::walls, col::thrust},
     .unit = "N",
     .rank = 0,
     .meaning = "normal soil force on the wall, F·n with n the wall chord's normal out of the "
                "soil: > 0 pressing, < 0 pulling (walls.csv)"},
    {.key = "reaction_z",
     .quantity = "vertical soil force",
     .owners = Owners::Walls,
     .source = {Read::Column, file::walls, col::reaction_z},
     .unit = "N",
     .meaning = "vertical soil force on the wall (wall friction for a vertical wall; walls.csv)"},
    // ---- structures (structures.csv): a wall's motion too ----
    {.key = "settlement",
     .quantity = "settlement",
     .owners = Owners::Structures,
     .source = {Read::Column, file::structures, col::settlement},
     .unit = "m",
     .rank = 1,
     .dof = Dof::Z,
     .meaning = "downward displacement of the structure's pivot"},
    {.key = "rotation",
     .quantity = "rotation",
     .owners = Owners::Structures,
     .source = {Read::Column, file::structures, col::rotation},
     .unit = "rad",
     .rank = 2,
     .dof = Dof::Rotation,
     .meaning = "rotation about the pivot, counter-clockwise positive"},
    {.key = "moment",
     .quantity = "soil moment",
     .owners = Owners::Structures,
     .source = {Read::Column, file::structures, col::moment},
     .unit = "N·m",
     .rank = 4,
     .meaning = "moment of the soil's forces about the pivot"},
    {.key = "displacement_x",
     .quantity = "horizontal displacement",
     .owners = Owners::Structures,
     .source = {Read::Column, file::structures, col::displacement_x},
     .unit = "m",
     .dof = Dof::X,
     .meaning = "horizontal displacement of the pivot"},
    // a wall's soil forces are its thrust and reaction_z (other_names)
    {.key = "force_x",
     .quantity = "horizontal soil force",
     .owners = Owners::Bodies,
     .source = {Read::Column, file::structures, col::force_x},
     .unit = "N",
     .meaning = "horizontal soil force on the structure"},
    {.key = "force_z",
     .quantity = "vertical soil force",
     .owners = Owners::Bodies,
     .source = {Read::Column, file::structures, col::force_z},
     .unit = "N",
     .meaning = "vertical soil force on the structure"},
    // ---- the surface ----
    {.key = "surface.elevation",
     .quantity = "surface elevation (mean over the width)",
     .source = {Read::SurfaceMean, file::surface, col::surface_bin},
     .unit = "m",
     .rank = 3,
     .meaning = "ground level; its increment is minus the surface subsidence"},
    // ---- profiles ----
    {.key = "pressure_profile",
     .quantity = "normal pressure along the wall",
     .subject = Subject::Profile,
     .owners = Owners::PressureTargets,
     .source = {Read::PressureBins, {}, col::pressure_bin},
     .reduction = Reduction::RestAndLateMean,
     .unit = "Pa",
     .scale = {1e-3, "kPa"},
     .role = Role::Shown,
     .record = "pressure_profiles",
     .meaning = "normal contact pressure on the probe's target per height bin, compression "
                "positive, at rest and over the late window"},
    {.key = "surface_subsidence_profile",
     .quantity = "surface subsidence",
     .subject = Subject::Profile,
     .source = {Read::SurfaceBins, file::surface, col::surface_bin},
     .reduction = Reduction::EndMinusRest,
     .unit = "m",
     .scale = {0.0, {}},
     .role = Role::Shown,
     .record = "surface_subsidence_profile",
     .meaning = "settlement of the surface per x bin from the load start to the end, down "
                "positive"},
};
static_assert(std::all_of(std::begin(kTable), std::end(kTable), consistent));

constexpr OtherName kOtherNames[] = {
    {Owners::Walls, col::reaction_x, col::thrust,
     "the horizontal soil force: equal to the thrust on a vertical wall"},
    {Owners::Walls, col::force_x, col::thrust,
     "structures.csv's horizontal soil force: walls.csv's reaction_x"},
    {Owners::Walls, col::force_z, col::reaction_z,
     "structures.csv's vertical soil force: walls.csv's reaction_z"},
    {Owners::Bodies,
     col::applied_moment,
     {},
     "the applied load's moment: the same history in both by construction"},
};

} // namespace

std::span<const Metric> metric_table() {
  return kTable;
}

std::span<const OtherName> other_names() {
  return kOtherNames;
}

} // namespace demfem::compare
