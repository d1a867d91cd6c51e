import * as THREE from 'three';
import { mergeGeometries } from 'three/addons/utils/BufferGeometryUtils.js';

// At the lowest quality level each link is drawn as one mesh: its parts'
// (simplified) geometries in the link's frame, merged, coloured per vertex.
// Software WebGL pays for every draw call, and the links of the arms people
// bring have several parts each (the demo cell: 45 draws become 15).

const _toLink = new THREE.Matrix4();
const _part = new THREE.Matrix4();

/**
 * One geometry for the parts of a link: `parts` are `[mesh, geometry, color]`
 * with `mesh` somewhere below `link`; `geometry` replaces the mesh's own (its
 * simplified copy). Positions, normals and colours only; null without parts.
 */
function mergedLinkGeometry( link, parts ) {

	if ( parts.length === 0 ) return null;
	link.updateWorldMatrix( true, true );
	_toLink.copy( link.matrixWorld ).invert();
	const pieces = parts.map( ( [ mesh, geometry, color ] ) => {

		const source = geometry.index ? geometry.toNonIndexed() : geometry;
		const piece = new THREE.BufferGeometry();
		piece.setAttribute( 'position', source.attributes.position.clone() );
		if ( source.attributes.normal ) piece.setAttribute( 'normal', source.attributes.normal.clone() );
		else piece.computeVertexNormals();
		piece.applyMatrix4( _part.multiplyMatrices( _toLink, mesh.matrixWorld ) );
		const colors = new Float32Array( piece.attributes.position.count * 3 );
		for ( let i = 0; i < colors.length; i += 3 ) colors.set( [ color.r, color.g, color.b ], i );
		piece.setAttribute( 'color', new THREE.BufferAttribute( colors, 3 ) );
		if ( source !== geometry ) source.dispose();
		return piece;

	} );
	const merged = mergeGeometries( pieces );
	for ( const piece of pieces ) piece.dispose();
	return merged;

}

export { mergedLinkGeometry };
